// A JSON object built key by key and written atomically: run summaries, benchmark records.
// nlohmann-json stays inside json_summary.cpp.
//
//   JsonSummary s;
//   s.set("dataset.frames", 500);            // dotted keys make nested objects
//   s.set("timing.tracking_ms", 12.5);
//   s.set_json("config", config_to_json(config));
//   s.write("out/summary.json");
#pragma once

#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace orpe {

class JsonSummary {
 public:
  JsonSummary();
  ~JsonSummary();
  JsonSummary(const JsonSummary& other);
  JsonSummary& operator=(const JsonSummary& other);

  /// Numbers and bools. Non-finite doubles are stored as null (JSON has no NaN).
  template <class T>
  requires std::is_arithmetic_v<T>
  void set(const std::string& dotted_key, T value) {
    if constexpr (std::is_same_v<T, bool>)
      set_bool(dotted_key, value);
    else if constexpr (std::is_integral_v<T> && std::is_signed_v<T>)
      set_int(dotted_key, value);
    else if constexpr (std::is_integral_v<T>)
      set_uint(dotted_key, value);
    else
      set_double(dotted_key, static_cast<double>(value));
  }
  void set(const std::string& dotted_key, const std::string& value);
  void set(const std::string& dotted_key, const char* value) {
    set(dotted_key, std::string(value));
  }
  void set(const std::string& dotted_key, const std::vector<double>& values);
  void set(const std::string& dotted_key, const std::vector<std::string>& values);
  /// Inserts parsed JSON text (e.g. config_to_json()). Throws std::invalid_argument if malformed.
  void set_json(const std::string& dotted_key, const std::string& json_text);
  /// Appends `row` (an object) to the array at dotted_key (created when absent).
  void append(const std::string& dotted_key, const JsonSummary& row);

  bool contains(const std::string& dotted_key) const;
  std::string dump(int indent = 2) const;
  /// Writes dump() atomically. Throws IoError naming the path.
  void write(const std::string& path) const;

 private:
  void set_bool(const std::string& key, bool v);
  void set_int(const std::string& key, long long v);
  void set_uint(const std::string& key, unsigned long long v);
  void set_double(const std::string& key, double v);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace orpe
