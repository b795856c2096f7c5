// File names and other text from outside are bytes; JSON (reports, the serve API) needs UTF-8.
#pragma once

#include <string>

namespace diffreg {

/// `bytes` with every byte that is not part of a valid UTF-8 sequence written as "\xNN" (and a
/// backslash that starts such an escape doubled), so any file name survives in JSON and can
/// be told apart. Valid UTF-8 comes back unchanged.
std::string escapeNonUtf8(const std::string& bytes);

}  // namespace diffreg
