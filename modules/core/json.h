// JSON text read strictly: the one parser of handle files and of the editor's request bodies.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace diffreg {

/// Parses `text` as one JSON value, more strictly than nlohmann's default in two ways: a key
/// twice in one object is an error (the default keeps the last), and so is a NUL byte (the
/// default ends the text there and ignores what follows) or a string or key with the escape
/// \u0000 (messages that name it would end there).
/// \throw std::invalid_argument with a message without nlohmann's exception prefix, e.g.
///        "parse error at line 1, column 2: ...", "key 'handles' twice in one object" or
///        "a NUL byte at offset 17".
nlohmann::json parseJsonStrictly(const std::string& text);

}  // namespace diffreg
