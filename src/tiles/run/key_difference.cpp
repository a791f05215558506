#include "key_difference.hpp"

#include <charconv>
#include <vector>

namespace pointfair::tiles::detail {
namespace {

struct Entry {
  std::string_view name, value;
};

// The key's entries in order; a word without '=' is its own name with an empty value.
std::vector<Entry> entries_of(std::string_view key) {
  std::vector<Entry> out;
  while (!key.empty()) {
    const std::size_t start = key.find_first_not_of(' ');
    if (start == std::string_view::npos) break;
    key.remove_prefix(start);
    const std::size_t end = std::min(key.find(' '), key.size());
    const std::string_view word = key.substr(0, end);
    const std::size_t eq = word.find('=');
    out.push_back(eq == std::string_view::npos ? Entry{word, {}} : Entry{word.substr(0, eq), word.substr(eq + 1)});
    key.remove_prefix(end);
  }
  return out;
}

// A real written to 17 digits (0.80000000000000004) in its shortest form that reads back the
// same (0.8); any other value as written.
std::string readable(std::string_view value) {
  double x = 0.0;
  const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), x);
  if (ec != std::errc() || end != value.data() + value.size()) return std::string(value);
  char text[32];
  const auto written = std::to_chars(text, text + sizeof text, x);
  return std::string(text, written.ptr);
}

const Entry* find(const std::vector<Entry>& entries, std::string_view name) {
  for (const Entry& e : entries)
    if (e.name == name) return &e;
  return nullptr;
}

}  // namespace

std::string key_differences(std::string_view stored, std::string_view current) {
  const std::vector<Entry> before = entries_of(stored), now = entries_of(current);
  std::string out;
  const auto add = [&](std::string_view name, std::string what) {
    if (!out.empty()) out += "; ";
    out += name;
    out += ": ";
    out += what;
  };
  for (const Entry& e : before) {
    const Entry* n = find(now, e.name);
    if (n == nullptr)
      add(e.name, readable(e.value) + " in the run, not set now");
    else if (n->value != e.value)
      add(e.name, readable(e.value) + " in the run, " + readable(n->value) + " now");
  }
  for (const Entry& n : now)
    if (find(before, n.name) == nullptr) add(n.name, "not in the run, " + readable(n.value) + " now");
  return out;
}

}  // namespace pointfair::tiles::detail
