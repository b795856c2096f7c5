// File names and other text from outside are bytes; JSON (reports, the serve API) needs UTF-8.
#pragma once

#include <string>
#include <string_view>

namespace diffreg {

/// Whether `name` is a non-empty run of printable ASCII (0x20 to 0x7e, spaces included): what
/// the mesh formats accept as a property name.
bool printableAscii(std::string_view name);

/// `bytes` with every byte that is not part of a valid UTF-8 sequence written as "\xNN" (and a
/// backslash that starts such an escape doubled), so any file name survives in JSON and can
/// be told apart. Valid UTF-8 comes back unchanged.
std::string escapeNonUtf8(const std::string& bytes);

/// `text` made fit for one line of a terminal: bytes that are not UTF-8, control characters
/// (an ESC would start a terminal escape sequence), C1 controls, direction overrides and line
/// separators written as "\xNN" byte by byte, line breaks and tabs as spaces, and the text cut
/// at a character boundary once the line has `maxBytes` bytes (the last character or escape may
/// pass it by a few), the rest replaced by "... (N more bytes)". A message that quotes a 15 MB
/// value stays readable.
std::string terminalLine(const std::string& text, size_t maxBytes = 2000);

/// Shortest text that reads back (strtod) as exactly `value`: plain decimals when no longer
/// than the exponent form ("0.01", "100", "-1"), else a tidy exponent ("1e6", "1e-12",
/// "1e308"); "nan", "inf", "-inf". The canonical text of Float parameters, and the numbers of
/// messages.
std::string formatNumber(double value);

/// `text` with each NUL byte written as "\x00": a message is a C string, which would end there.
std::string nulShown(const std::string& text);

}  // namespace diffreg
