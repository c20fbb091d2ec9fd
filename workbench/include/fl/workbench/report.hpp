// The compare report as files a person opens: report.html (self-contained: the ranking of
// where the model fails, overlays and residuals per trial as inline SVG) and report.json (the
// same numbers for scripts and for the run history).
#pragma once

#include <filesystem>
#include <string>

#include "fl/workbench/compare.hpp"

namespace fl::workbench {

[[nodiscard]] std::string report_json(const CompareReport& report);
[[nodiscard]] std::string report_html(const CompareReport& report);
// Writes folder/report.json and folder/report.html (creating the folder); throws
// std::runtime_error naming the file that cannot be written.
void write_report(const CompareReport& report, const std::filesystem::path& folder);

}  // namespace fl::workbench
