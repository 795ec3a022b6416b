// How counts, small probabilities, uncertain numbers and times read in text a technician
// reads (the demo's narrative, a command's summary, the report): "1 ray", "3 rays";
// "p < 0.001", "p > 0.99", "p = 0.034"; "0.00042" rather than "0.000"; a stored time to
// the second with its zone.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace armsig {

// "1 ray", "0 rays", "3 rays"; an irregular plural given ("1 degree of freedom",
// "2 degrees of freedom"). The plural is `singular` + "s" when none is given.
std::string Count(int64_t n, std::string_view singular, std::string_view plural = {});

// A p-value in words a reader can act on: "p < 0.001" below 0.001, "p > 0.99" above 0.99,
// else two significant digits ("p = 0.034", "p = 0.5"); "p = —" when not a number.
std::string PValueText(double p);

// `value` in plain decimal notation with `digits` significant digits, never an exponent
// and never a lone "0.000" for a small non-zero value: 0.000423 → "0.00042",
// 14.67 → "15" (2 digits), 0 → "0", -0.0 → "0". Values beyond ±1e9 or below ±1e-9 (but not
// zero) fall back to the shortest exponent form; NaN and infinities as "nan", "inf".
std::string Significant(double value, int digits = 2);

// `value` with as many decimals as its uncertainty `sigma` needs for two significant digits
// of the sigma ("0.1413 ± 0.00042" → value "0.14130", sigma "0.00042"); at least
// `min_decimals`, at most 9.
int DecimalsForSigma(double sigma, int min_decimals = 0);

// A stored ISO-8601 time ("2026-11-27T12:44:19.424Z", "2026-11-27T12:44:19+02:00") to the
// second with its zone kept: "2026-11-27T12:44:19Z", "2026-11-27T12:44:19+02:00". A text
// that is not such a time is returned as it is.
std::string TimeToTheSecond(std::string_view iso);

}  // namespace armsig
