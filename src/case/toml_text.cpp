// TOML text for the case and sweep readers: parse_toml (toml++ behind a
// lexer that guards it against non-ASCII input) and the wording helpers of
// one-line error messages (toml_text.hpp).

#include "stickslip/case/toml_text.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <numeric>
#include <sstream>

namespace stickslip {
namespace toml_text {

using namespace std::string_literals;

// The fewest %g digits that read back as x: 0.0005, 1e-12, 0.1 (not 0.10000000000000001).
std::string fmt(double x) {
  char buf[32];
  for (int digits = 1;; ++digits)
    if (std::snprintf(buf, sizeof buf, "%.*g", digits, x);
        digits >= 17 || std::strtod(buf, nullptr) == x)
      return buf;
}

// User text goes into one-line messages, so control characters are escaped.
std::string printable(std::string_view s) {
  std::string out;
  for (unsigned char ch : s) {
    if (ch >= 0x20 && ch != 0x7f) {
      out += static_cast<char>(ch);
      continue;
    }
    char hex[5];
    std::snprintf(hex, sizeof hex, "\\x%02x", ch);
    out += hex;
  }
  return out;
}

std::string type_name(const toml::node& n) {
  std::ostringstream name;  // toml++'s spelling: integer, floating-point, string, array, ...
  name << n.type();
  return name.str();
}

// Edits (insert, delete, substitute, swap two neighbours) from a to b: a
// swap ("rnu" for "run") is one typo, not two.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> before(b.size() + 1), row(b.size() + 1), now(b.size() + 1);
  std::iota(row.begin(), row.end(), std::size_t{0});
  for (std::size_t i = 1; i <= a.size(); ++i) {
    now[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      now[j] = std::min({row[j] + 1, now[j - 1] + 1, row[j - 1] + (a[i - 1] != b[j - 1])});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        now[j] = std::min(now[j], before[j - 2] + 1);
    }
    before = row;
    row = now;
  }
  return row.back();
}

// The nearest valid name when it is close enough to be a typo, else the list of valid names.
std::string suggest(std::string_view name, const std::vector<std::string_view>& valid) {
  auto dist = [&](std::string_view v) { return edit_distance(name, v); };
  auto best = std::min_element(valid.begin(), valid.end(),
                               [&](auto a, auto b) { return dist(a) < dist(b); });
  if (best != valid.end() && dist(*best) <= std::max<std::size_t>(1, name.size() / 3))
    return " (did you mean '"s + std::string(*best) + "'?)";
  std::string all;
  for (auto v : valid) all += (all.empty() ? "" : ", ") + std::string(v);
  return " (valid: " + all + ")";
}

// Decodes the UTF-8 sequence at s[i] into `cp`; returns its length, 0 if it is not valid UTF-8.
std::size_t utf8_at(std::string_view s, std::size_t i, char32_t& cp) {
  const auto lead = static_cast<unsigned char>(s[i]);
  const std::size_t n = lead < 0x80             ? 1
                        : (lead & 0xe0) == 0xc0 ? 2
                        : (lead & 0xf0) == 0xe0 ? 3
                        : (lead & 0xf8) == 0xf0 ? 4
                                                : 0;
  if (n == 0 || n > s.size() - i) return 0;
  cp = n == 1 ? lead : lead & (0x7f >> n);
  for (std::size_t k = 1; k < n; ++k) {
    const auto next = static_cast<unsigned char>(s[i + k]);
    if ((next & 0xc0) != 0x80) return 0;
    cp = cp << 6 | (next & 0x3f);
  }
  constexpr char32_t shortest[] = {0, 0, 0x80, 0x800, 0x10000};  // longer is overlong
  if (cp < shortest[n] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  return n;
}

std::string code_point(char32_t cp) {
  char name[16];
  std::snprintf(name, sizeof name, "U+%04X", static_cast<unsigned>(cp));
  return name;
}

// toml++ 3.3.0 (Debian 12's libtomlplusplus3) executes __builtin_unreachable(),
// which is undefined behaviour, when it asks whether some non-ASCII characters
// (U+00A1..U+0499 and others) are whitespace: upstream issues #190 and #295,
// found here by scripts/fuzz. It asks for a non-ASCII character outside strings
// and comments (always an error in TOML: toml++ reads a bare value such as
// 4'§' up to the next whitespace, ',', ']', '}' or '#', quotes included), right
// after a backslash in a multi-line basic string (an invalid escape), and first
// after a line-ending backslash there (valid TOML). So toml++ never sees these:
// the lexer below (TOML 1.0 strings, comments and where a string may start)
// reports the first two as malformed TOML and replaces the third by its \U
// escape, which means the same. Lines are kept, so messages stay right.
toml::table parse_toml(std::string_view text, std::string_view source) {
  // A UTF-8 byte-order mark, which Windows editors write at a file's start,
  // marks the encoding and is no part of the text (CRLF line ends toml++
  // reads as they are).
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  enum class State { normal, comment, basic, literal, ml_basic, ml_literal } state = State::normal;
  enum class Next { key, value, other } next = Next::key;  // what may start here (normal state)
  bool in_value = false;  // right of an '=', until the line or the inline table ends
  std::string brackets;   // open ones: '[' array, 'h' table header, '{' inline table
  char prev = '\n';       // the previous character outside strings and comments
  bool escaped = false;   // after a backslash in a basic string
  bool line_end = false;  // skipping whitespace after a line-ending backslash (ml_basic)
  std::string fixed;      // text[0, copied) with the escapes put in, once one is needed
  std::size_t copied = 0;
  std::size_t bad = text.size();  // where the error is, if any
  std::string what;
  std::uint32_t line = 1;
  auto run_of = [&](std::size_t i, char quote) {
    std::size_t n = 0;
    while (i + n < text.size() && text[i + n] == quote) ++n;
    return n;
  };
  for (std::size_t i = 0; i < text.size();) {
    char32_t cp = 0;
    const std::size_t len = utf8_at(text, i, cp);
    const char ch = text[i];
    const bool space = ch == ' ' || ch == '\t' || ch == '\r' || ch == '\n';
    if (len == 0) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02x", static_cast<unsigned char>(ch));
      what = "invalid UTF-8 (byte "s + hex + ")";
      bad = i;
      break;
    }
    if (state == State::comment && ch == '\n') state = State::normal;
    if (state == State::normal) {
      if (cp >= 0x80) {
        what = "unexpected character " + code_point(cp) + " outside a string or comment";
        bad = i;
        break;
      }
      const bool array = !brackets.empty() && brackets.back() == '[';
      const bool table = !brackets.empty() && brackets.back() == '{';
      switch (ch) {
        case ' ':
        case '\t':
        case '\r':
          break;
        case '\n':
          if (brackets.empty()) in_value = false, next = Next::key;
          break;
        case '#':
          state = State::comment;
          break;
        case '=':
          next = in_value ? Next::other : Next::value;
          in_value = true;
          break;
        case '.':
          next = in_value ? Next::other : Next::key;
          break;
        case ',':
          if (table) in_value = false;
          next = array ? Next::value : table ? Next::key : Next::other;
          break;
        case '[':
          if (next == Next::value) {
            brackets += '[';
          } else if (!in_value && next == Next::key &&
                     (brackets.empty() || (brackets.back() == 'h' && prev == '['))) {
            brackets += 'h';
          } else {
            next = Next::other;
          }
          break;
        case ']':
          if (!brackets.empty() && !table) brackets.pop_back();
          next = Next::other;
          break;
        case '{':
          if (next == Next::value)
            brackets += '{', in_value = false, next = Next::key;
          else
            next = Next::other;
          break;
        case '}':
          if (table) brackets.pop_back(), in_value = true;
          next = Next::other;
          break;
        case '"':
        case '\'':
          if (next != Next::other) {  // else it is read as part of a bare value: no string
            const bool multi_line = run_of(i, ch) >= 3;
            state = ch == '"' ? (multi_line ? State::ml_basic : State::basic)
                              : (multi_line ? State::ml_literal : State::literal);
            next = Next::other;
            prev = ch;
            i += multi_line ? 3 : 1;
            continue;
          }
          break;
        default:
          next = Next::other;
      }
      prev = ch;
    } else if (state == State::ml_basic && escaped && cp >= 0x80) {
      what = "unknown escape sequence '\\" + std::string(text.substr(i, len)) + "' (" +
             code_point(cp) + ")";
      bad = i;
      break;
    } else if (escaped) {  // the character after a backslash is never special
      escaped = false;
      line_end = state == State::ml_basic && space;
    } else if (state == State::ml_basic && line_end && space) {
    } else if (state == State::ml_basic || state == State::ml_literal) {
      if (line_end && cp >= 0x80) {
        char escape[12];
        std::snprintf(escape, sizeof escape, "\\U%08X", static_cast<unsigned>(cp));
        fixed.append(text.substr(copied, i - copied)).append(escape);
        copied = i + len;
      }
      line_end = false;
      const char quote = state == State::ml_basic ? '"' : '\'';
      if (ch == '\\' && state == State::ml_basic) {
        escaped = true;
      } else if (ch == quote) {  // """ closes, taking up to two more quotes with it
        const std::size_t n = run_of(i, quote);
        if (n >= 3) state = State::normal;
        i += n >= 3 ? std::min<std::size_t>(n, 5) : n;
        continue;
      }
    } else if (state == State::basic || state == State::literal) {
      if (ch == '\\' && state == State::basic)
        escaped = true;
      else if (ch == (state == State::basic ? '"' : '\'') || ch == '\n')
        state = State::normal;  // at a newline, toml++ reports the unclosed string
    }
    if (ch == '\n') ++line;
    i += len;
  }
  try {
    if (bad == text.size()) {
      if (copied == 0) return toml::parse(text, source);
      fixed.append(text.substr(copied));
      return toml::parse(fixed, source);
    }
    // An error on an earlier line wins: toml++ reads the text up to `bad`, with
    // the string cut there closed, and reports the first error in it, if any.
    fixed.append(text.substr(copied, bad - copied));
    if (escaped) fixed.pop_back();  // the backslash
    if (state == State::basic) fixed += '"';
    if (state == State::literal) fixed += '\'';
    if (state == State::ml_basic) fixed += "\"\"\"";
    if (state == State::ml_literal) fixed += "'''";
    (void)toml::parse(fixed, source);
  } catch (const toml::parse_error& e) {
    if (bad == text.size() || e.source().begin.line < line)
      throw TomlSyntaxError{printable(e.description()), e.source().begin.line};
  }
  throw TomlSyntaxError{what, line};
}

}  // namespace toml_text

}  // namespace stickslip
