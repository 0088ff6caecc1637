// Printing the server's answers for people: numbers without noise, vectors as "x, y, z",
// aligned "label  value" lines. --json bypasses all of this (printRaw).
#pragma once

#include <array>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace myriad::cli {

// The body as it came, with a final newline.
void printRaw(std::ostream& out, const std::string& body);

std::string formatNumber(double value);  // 6 significant digits, no trailing zeros
std::string formatVec(const std::array<double, 3>& v);  // "1, 2.5, -3"
std::string formatBytes(uint64_t bytes);                 // "12.3 MiB"
std::string onOff(bool value);

// "label   value" lines with the values aligned.
void printFields(std::ostream& out, const std::vector<std::pair<std::string, std::string>>& fields);

// A table with a header row; columns padded to their widest cell.
void printTable(std::ostream& out, const std::vector<std::string>& header,
                const std::vector<std::vector<std::string>>& rows);

}  // namespace myriad::cli
