// Typed reads and writes of the armsig database, one header per table family. Callers
// group writes that belong together in one SQLite::Transaction; every function is a
// plain statement. All of armsig's SQL lives in db/.
#pragma once

#include "db/calibrations.h"
#include "db/controllers.h"
#include "db/observations.h"
#include "db/robots.h"
#include "db/sessions.h"
