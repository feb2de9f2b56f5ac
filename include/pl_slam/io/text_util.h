// Small, locale-independent text helpers shared by the dataset and trajectory readers and
// writers: whole-file reading, line/field splitting, strict number parsing and shortest
// round-trip number formatting.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace pl_slam {
namespace text {

/// Reads a whole file. Throws InputError "<path>: cannot open (<reason>)".
std::string ReadFile(const std::string& path);

/// Splits content into lines; '\n' and "\r\n" endings, a missing final newline is fine.
std::vector<std::string_view> SplitLines(std::string_view content);

/// Removes leading and trailing spaces, tabs and carriage returns.
std::string_view Trim(std::string_view s);

/// True for blank lines and lines whose first non-blank character is '#'.
bool IsBlankOrComment(std::string_view line);

/// Splits on `sep` (each field trimmed); an empty line gives one empty field.
std::vector<std::string_view> SplitOn(std::string_view line, char sep);

/// Splits on runs of whitespace (and commas when `commas_too`); no empty fields.
std::vector<std::string_view> SplitWhitespace(std::string_view line, bool commas_too = false);

/// Parses the whole of s (after trimming) as a finite double; false otherwise. Accepts a
/// leading '+', never depends on the C locale.
bool ParseDouble(std::string_view s, double* value);

/// Parses the whole of s (after trimming) as a base-10 signed 64-bit integer.
bool ParseInt64(std::string_view s, int64_t* value);

/// Shortest decimal text that parses back to exactly `value` (std::to_chars).
std::string FormatDouble(double value);

/// Lower-case ASCII copy.
std::string ToLower(std::string_view s);

}  // namespace text
}  // namespace pl_slam
