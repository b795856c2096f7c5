#include <diffreg/core/json.h>

#include <algorithm>
#include <set>
#include <stdexcept>
#include <vector>

namespace diffreg {
namespace {

struct DuplicateKey {
  std::string key;
};

// A string or key holding the escape \u0000: names and messages end at it in C strings, so
// it is refused as the raw NUL byte is.
struct NulInString {};

}  // namespace

nlohmann::json parseJsonStrictly(const std::string& text) {
  using json = nlohmann::json;
  if (const size_t nul = text.find('\0'); nul != std::string::npos)
    throw std::invalid_argument("a NUL byte at offset " + std::to_string(nul));
  std::vector<std::set<std::string>> keys;  // those of each object being read
  const json::parser_callback_t seen = [&keys](int, json::parse_event_t event, json& value) {
    if ((event == json::parse_event_t::key || event == json::parse_event_t::value) &&
        value.is_string() && value.get_ref<const std::string&>().find('\0') != std::string::npos)
      throw NulInString{};
    if (event == json::parse_event_t::object_start) {
      keys.emplace_back();
    } else if (event == json::parse_event_t::object_end) {
      keys.pop_back();
    } else if (event == json::parse_event_t::key && !keys.empty() &&
               !keys.back().insert(value.get<std::string>()).second) {
      throw DuplicateKey{value.get<std::string>()};
    }
    return true;
  };
  try {
    return json::parse(text, seen);
  } catch (const NulInString&) {
    throw std::invalid_argument("a string holds the character \\u0000 (NUL)");
  } catch (const DuplicateKey& d) {
    throw std::invalid_argument("key '" + d.key + "' twice in one object");
  } catch (const json::exception& e) {  // parse errors, numbers beyond double
    std::string what = e.what();
    // "[json.exception.parse_error.101] parse error at line 1, column 2: ..." -> after "] "
    const size_t close = what.find("] ");
    if (close != std::string::npos) what = what.substr(close + 2);
    std::replace(what.begin(), what.end(), '\n', ' ');
    throw std::invalid_argument(what);
  }
}

}  // namespace diffreg
