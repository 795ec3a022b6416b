import numpy as np; print("\n".join(str(i) for i in np.random.default_rng(0).permutation(2773)))
