// meshcvt CLI: a small JSON writer for --json output and reports (objects, arrays, numbers,
// strings), so the CLI needs no JSON library for output alone.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

namespace meshcvt::cli {

class Json {
 public:
  Json& begin_object(std::string_view key = {}) { open(key, '{'); return *this; }
  Json& end_object() { close('}'); return *this; }
  Json& begin_array(std::string_view key = {}) { open(key, '['); return *this; }
  Json& end_array() { close(']'); return *this; }

  Json& value(std::string_view key, std::string_view s) { prefix(key); quote(s); return *this; }
  Json& value(std::string_view key, const char* s) { return value(key, std::string_view(s)); }
  Json& value(std::string_view key, const std::string& s) { return value(key, std::string_view(s)); }
  Json& value(std::string_view key, bool b) { prefix(key); out_ += b ? "true" : "false"; return *this; }
  Json& value(std::string_view key, double d) {
    prefix(key);
    if (!std::isfinite(d)) { out_ += "null"; return *this; }
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", d);
    out_ += buf;
    return *this;
  }
  Json& value(std::string_view key, float f) { return value(key, double(f)); }
  /// Every digit that tells the double apart (the shortest decimal that reads back as d), where 9
  /// significant digits are too few: coordinates in a far mesh's frame.
  Json& exact(std::string_view key, double d) {
    prefix(key);
    if (!std::isfinite(d)) { out_ += "null"; return *this; }
    char buf[32];
    out_.append(buf, std::to_chars(buf, buf + sizeof buf, d).ptr);
    return *this;
  }
  template <typename I>
    requires std::is_integral_v<I>
  Json& value(std::string_view key, I i) {
    prefix(key);
    out_ += std::to_string(i);
    return *this;
  }
  /// Array element (no key).
  template <typename T>
  Json& item(const T& v) { return value({}, v); }

  const std::string& str() const { return out_; }

 private:
  void prefix(std::string_view key) {
    if (!first_.empty()) {
      if (!first_.back()) out_ += ',';
      first_.back() = false;
      out_ += '\n';
      out_.append(2 * first_.size(), ' ');
    }
    if (!key.empty()) { quote(key); out_ += ": "; }
  }
  void open(std::string_view key, char c) { prefix(key); out_ += c; first_.push_back(true); }
  void close(char c) {
    bool empty = first_.back();
    first_.pop_back();
    if (!empty) { out_ += '\n'; out_.append(2 * first_.size(), ' '); }
    out_ += c;
    if (first_.empty()) out_ += '\n';
  }
  void quote(std::string_view s) {
    out_ += '"';
    for (char ch : s) {
      unsigned char u = static_cast<unsigned char>(ch);
      if (ch == '"' || ch == '\\') { out_ += '\\'; out_ += ch; }
      else if (u < 0x20) { char buf[8]; std::snprintf(buf, sizeof buf, "\\u%04x", u); out_ += buf; }
      else out_ += ch;
    }
    out_ += '"';
  }
  std::string out_;
  std::vector<bool> first_;
};

}  // namespace meshcvt::cli
