#include "orpe/io/json_summary.h"

#include <cmath>
#include <ostream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "orpe/core/atomic_file.h"

namespace orpe {

struct JsonSummary::Impl {
  nlohmann::json root = nlohmann::json::object();

  /// The node at `dotted_key`, creating objects along the way (a non-object on the way is
  /// replaced).
  nlohmann::json& at(const std::string& dotted_key) {
    if (dotted_key.empty()) throw std::invalid_argument("JsonSummary: empty key");
    nlohmann::json* node = &root;
    size_t start = 0;
    while (true) {
      const size_t dot = dotted_key.find('.', start);
      const std::string part =
          dotted_key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
      if (part.empty())
        throw std::invalid_argument("JsonSummary: malformed key '" + dotted_key + "'");
      if (!node->is_object()) *node = nlohmann::json::object();
      node = &(*node)[part];
      if (dot == std::string::npos) return *node;
      start = dot + 1;
    }
  }
  const nlohmann::json* find(const std::string& dotted_key) const {
    const nlohmann::json* node = &root;
    size_t start = 0;
    while (true) {
      const size_t dot = dotted_key.find('.', start);
      const std::string part =
          dotted_key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
      if (!node->is_object() || !node->contains(part)) return nullptr;
      node = &node->at(part);
      if (dot == std::string::npos) return node;
      start = dot + 1;
    }
  }
};

JsonSummary::JsonSummary() : impl_(std::make_unique<Impl>()) {}
JsonSummary::~JsonSummary() = default;
JsonSummary::JsonSummary(const JsonSummary& other) : impl_(std::make_unique<Impl>(*other.impl_)) {}
JsonSummary& JsonSummary::operator=(const JsonSummary& other) {
  if (this != &other) *impl_ = *other.impl_;
  return *this;
}

void JsonSummary::set_bool(const std::string& key, bool v) {
  impl_->at(key) = v;
}
void JsonSummary::set_int(const std::string& key, long long v) {
  impl_->at(key) = v;
}
void JsonSummary::set_uint(const std::string& key, unsigned long long v) {
  impl_->at(key) = v;
}
void JsonSummary::set_double(const std::string& key, double v) {
  impl_->at(key) = std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}
void JsonSummary::set(const std::string& key, const std::string& value) {
  impl_->at(key) = value;
}
void JsonSummary::set(const std::string& key, const std::vector<double>& values) {
  nlohmann::json a = nlohmann::json::array();
  for (double v : values)
    a.push_back(std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr));
  impl_->at(key) = std::move(a);
}
void JsonSummary::set(const std::string& key, const std::vector<std::string>& values) {
  impl_->at(key) = values;
}
void JsonSummary::set_json(const std::string& key, const std::string& json_text) {
  try {
    impl_->at(key) = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument("JsonSummary::set_json('" + key + "'): " + e.what());
  }
}
void JsonSummary::append(const std::string& key, const JsonSummary& row) {
  nlohmann::json& node = impl_->at(key);
  if (!node.is_array()) node = nlohmann::json::array();
  node.push_back(row.impl_->root);
}
bool JsonSummary::contains(const std::string& key) const {
  return impl_->find(key) != nullptr;
}
std::string JsonSummary::dump(int indent) const {
  return impl_->root.dump(indent);
}
void JsonSummary::write(const std::string& path) const {
  const std::string text = dump() + "\n";
  write_file_atomic(path, [&](std::ostream& os) { os << text; });
}

}  // namespace orpe
