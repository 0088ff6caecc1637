// Turns an error response into the one line `myriad` prints: "<detail> (<status> <type name>)",
// where the type name is the last segment of an RFC 9457 problem type
// (https://myriad.dev/problems/not-found -> not-found). Pure, no I/O.
#pragma once

#include <string>

namespace myriad::cli {

// `contentType` and `body` as received. Never throws: a body that is not a problem still gives a
// line (its first line, shortened, with the HTTP reason phrase).
std::string describeErrorResponse(int status, const std::string& contentType,
                                  const std::string& body);

// Text from outside (a server's detail) made fit for one line of a terminal: control characters
// become spaces, runs of spaces collapse, and it is cut at `maxLength` with "...".
std::string oneLine(const std::string& text, size_t maxLength = 300);

}  // namespace myriad::cli
