// The recalibration report: one self-contained HTML page (figures drawn with OpenCV,
// embedded as PNG data URIs, no JavaScript, an A4 print stylesheet) a technician would
// rather look at than read.
//
// A small module of its own: what it is made of (report_input.h), its numbers
// (report_statistics.h), its figures (report_figures.h), its page sections
// (report_page.h) and what it reads from the store (report_sources.h); WriteReport puts
// them together.
#pragma once

#include <string>

#include "report/report_input.h"
#include "report/report_page.h"
#include "report/report_sources.h"
#include "report/report_statistics.h"

namespace armsig::report {

// Writes DIR/index.html and DIR/*.png; returns the HTML path. Throws on I/O failure.
// Temporary files a crashed writer left beside them (older than a minute) are removed.
std::string WriteReport(const std::string& dir, const ReportInput& input);
// The page of a night that fitted nothing (drift suspected, too few configurations since
// the change for a fit of their own; exit 5): the decision, the drift line and its causes, the
// window of sessions tested against the active set, the drift chart and the versions. The
// figures of an earlier report in the folder are removed: they would describe another night.
// `input.run` and `input.model` are not used. Returns the page's path.
std::string WriteDecisionReport(const std::string& dir, const ReportInput& input);

// Removes the temporary files (NAME.tmp.XXXXXX, io/atomic_file.h) of the report's own
// files left in DIR by a writer that died, when older than `min_age_s`. Returns how many.
int RemoveReportDebris(const std::string& dir, double min_age_s);

}  // namespace armsig::report
