// Generic JSON / text conversion of Params structs (see params.h). Header-only; pulls nlohmann-json.
#pragma once

#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "orpe/core/config_keys.h"
#include "orpe/core/error.h"
#include "orpe/core/params.h"

namespace orpe {
namespace params_detail {

template <class T>
std::string type_name() {
  if constexpr (std::is_same_v<T, bool>) return "bool";
  else if constexpr (std::is_integral_v<T>) return "int";
  else if constexpr (std::is_floating_point_v<T>) return "double";
  else return "string";
}

template <class T>
std::string to_text(const T& v) {
  if constexpr (std::is_same_v<T, bool>) return v ? "true" : "false";
  else if constexpr (std::is_same_v<T, std::string>) return v;
  else {
    std::ostringstream os;
    os.precision(10);
    os << v;
    return os.str();
  }
}

/// Parses `text` into `out`; throws ConfigError naming the key on failure.
template <class T>
void from_text(const std::string& key, const std::string& text, T& out) {
  if constexpr (std::is_same_v<T, bool>) {
    if (text == "true" || text == "1" || text == "on" || text == "yes") out = true;
    else if (text == "false" || text == "0" || text == "off" || text == "no") out = false;
    else throw ConfigError("parameter '" + key + "': expected a boolean, got '" + text + "'");
  } else if constexpr (std::is_same_v<T, std::string>) {
    out = text;
  } else {
    std::istringstream is(text);
    T v{};
    is >> v;
    if (is.fail() || !is.eof())
      throw ConfigError("parameter '" + key + "': expected " + type_name<T>() + ", got '" + text + "'");
    out = v;
  }
}

}  // namespace params_detail

template <class P>
nlohmann::json params_to_json(P p) {
  nlohmann::json j = nlohmann::json::object();
  p.visit([&](const char* key, auto& field, const char*) { j[key] = field; });
  return j;
}

/// The keys of P, in visit order.
template <class P>
std::vector<std::string> params_keys(P p) {
  std::vector<std::string> keys;
  p.visit([&](const char* key, auto&, const char*) { keys.emplace_back(key); });
  return keys;
}

/// Sets fields from a JSON object; unknown keys and wrong types are errors naming `section.key`.
template <class P>
void params_from_json(P& p, const nlohmann::json& j, const std::string& section) {
  if (!j.is_object()) throw ConfigError("config section '" + section + "' must be an object");
  for (auto it = j.begin(); it != j.end(); ++it) {
    bool found = false;
    p.visit([&](const char* key, auto& field, const char*) {
      if (it.key() != key) return;
      found = true;
      using T = std::decay_t<decltype(field)>;
      try {
        if constexpr (std::is_same_v<T, bool>) {
          if (!it.value().is_boolean()) throw std::runtime_error("not a boolean");
        } else if constexpr (std::is_integral_v<T>) {
          // 1.5 or 1e8 for an integer is refused, not truncated; so is a value beyond the type's range.
          if (!it.value().is_number_integer()) throw std::runtime_error("not an integer: " + it.value().dump());
          const bool fits = it.value().is_number_unsigned()
                                ? it.value().template get<std::uint64_t>() <=
                                      static_cast<std::uint64_t>(std::numeric_limits<T>::max())
                                : (it.value().template get<std::int64_t>() >=
                                       static_cast<std::int64_t>(std::numeric_limits<T>::min()) &&
                                   it.value().template get<std::int64_t>() <=
                                       static_cast<std::int64_t>(std::numeric_limits<T>::max()));
          if (!fits) throw std::runtime_error("out of range: " + it.value().dump());
        } else if constexpr (std::is_arithmetic_v<T>) {
          if (!it.value().is_number()) throw std::runtime_error("not a number");
        } else {
          if (!it.value().is_string()) throw std::runtime_error("not a string");
        }
        field = it.value().template get<T>();
      } catch (const std::exception& e) {
        throw ConfigError("config key '" + section + "." + it.key() + "': expected " +
                          params_detail::type_name<T>() + " (" + e.what() + ")");
      }
    });
    if (!found) throw ConfigError(unknown_config_key_message(section, it.key(), params_keys(p)));
  }
}

/// Sets one field from text; returns false when `key` is not a field of P.
template <class P>
bool params_set(P& p, const std::string& key, const std::string& value, const std::string& section) {
  bool found = false;
  p.visit([&](const char* k, auto& field, const char*) {
    if (key != k) return;
    found = true;
    params_detail::from_text(section + "." + key, value, field);
  });
  return found;
}

template <class P>
void params_docs(P p, const std::string& section, std::vector<ParamDoc>& out) {
  p.visit([&](const char* key, auto& field, const char* doc) {
    using T = std::decay_t<decltype(field)>;
    out.push_back({section + "." + key, params_detail::type_name<T>(),
                   params_detail::to_text(field), doc});
  });
}

}  // namespace orpe
