#pragma once
/// @file
/// @brief The pieces of the tools' HTML reports: one self-contained page (its style inline, no
/// script, no network), table cells and numbers.

#include <string>

namespace sid::app {

/// @brief v as printf's format writes it.
std::string html_number(double v, const char* format = "%.4g");

/// @brief A fraction as a percentage with three significant digits ("12.3 %").
std::string html_percent(double fraction);

/// @brief A table cell holding text (escaped).
std::string html_cell(const std::string& text);

/// @brief A right-aligned table cell holding a number.
std::string html_number_cell(double v, const char* format = "%.4g");

/// @brief A table row: a heading cell, then one with value.
std::string html_row(const std::string& head, const std::string& value);

/// @brief The whole page: title in its head, body as it is, the reports' one style sheet
/// (classes: verdict, verdict bad, warning; td.number).
std::string html_document(const std::string& title, const std::string& body);

}  // namespace sid::app
