// geocontact: a small dependency-free JSON reader (RFC 8259), enough for `geocontact.law/1`
// parameter files. Header-only C++17. Errors throw geocontact::InputError with line and column.
#ifndef GEOCONTACT_JSON_HPP
#define GEOCONTACT_JSON_HPP

#include <cstdlib>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace geocontact {

// Bad user input: the message is one line naming the field (as the Python InputError).
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string &message) : std::runtime_error(message) {}
};

namespace json {

struct Value {
  enum Kind { NUL, BOOL, NUMBER, STRING, ARRAY, OBJECT };
  Kind kind = NUL;
  bool boolean = false;
  double number = 0.0;
  std::string string;
  std::vector<Value> array;
  // Keys keep the order they were written in; duplicates are rejected by the parser.
  std::vector<std::pair<std::string, Value>> object;

  bool is_object() const { return kind == OBJECT; }
  const Value *find(const std::string &key) const
  {
    for (const auto &kv : object)
      if (kv.first == key) return &kv.second;
    return nullptr;
  }
};

inline const char *kind_name(Value::Kind kind)
{
  static const char *names[] = {"null", "true/false", "a number", "a string", "an array",
                                "an object"};
  return names[kind];
}

class Parser {
 public:
  Parser(const std::string &text, std::string source) : text_(text), source_(std::move(source)) {}

  Value parse_document()
  {
    skip_space();
    Value v = parse_value(0);
    skip_space();
    if (pos_ != text_.size()) fail("unexpected text after the JSON value");
    return v;
  }

 private:
  static constexpr int kMaxDepth = 64;
  const std::string &text_;
  std::string source_;
  size_t pos_ = 0;

  [[noreturn]] void fail(const std::string &what) const
  {
    size_t line = 1, column = 1;
    for (size_t i = 0; i < pos_ && i < text_.size(); ++i) {
      if (text_[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    throw InputError("params: malformed JSON in " + source_ + ": " + what + " at line " +
                     std::to_string(line) + " column " + std::to_string(column));
  }

  void skip_space()
  {
    while (pos_ < text_.size() &&
           (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\n' ||
            text_[pos_] == '\r'))
      ++pos_;
  }

  bool consume(const char *word)
  {
    size_t n = 0;
    while (word[n]) ++n;
    if (text_.compare(pos_, n, word) == 0) {
      pos_ += n;
      return true;
    }
    return false;
  }

  Value parse_value(int depth)
  {
    if (depth > kMaxDepth) fail("nesting too deep");
    if (pos_ >= text_.size()) fail("unexpected end of input");
    const char c = text_[pos_];
    Value v;
    if (c == '{') return parse_object(depth);
    if (c == '[') return parse_array(depth);
    if (c == '"') {
      v.kind = Value::STRING;
      v.string = parse_string();
      return v;
    }
    if (consume("true")) {
      v.kind = Value::BOOL;
      v.boolean = true;
      return v;
    }
    if (consume("false")) {
      v.kind = Value::BOOL;
      return v;
    }
    if (consume("null")) return v;
    if (c == '-' || (c >= '0' && c <= '9')) return parse_number();
    fail(std::string("unexpected character '") + c + "'");
  }

  Value parse_number()
  {
    const size_t start = pos_;
    auto digits = [&]() {
      const size_t from = pos_;
      while (pos_ < text_.size() && text_[pos_] >= '0' && text_[pos_] <= '9') ++pos_;
      return pos_ > from;
    };
    if (text_[pos_] == '-') ++pos_;
    if (pos_ < text_.size() && text_[pos_] == '0')
      ++pos_;
    else if (!digits())
      fail("invalid number");
    if (pos_ < text_.size() && text_[pos_] == '.') {
      ++pos_;
      if (!digits()) fail("invalid number");
    }
    if (pos_ < text_.size() && (text_[pos_] == 'e' || text_[pos_] == 'E')) {
      ++pos_;
      if (pos_ < text_.size() && (text_[pos_] == '+' || text_[pos_] == '-')) ++pos_;
      if (!digits()) fail("invalid number");
    }
    Value v;
    v.kind = Value::NUMBER;
    // strtod rounds correctly (as Python's float()), so both sides read the same doubles.
    v.number = std::strtod(text_.substr(start, pos_ - start).c_str(), nullptr);
    return v;
  }

  static void append_utf8(std::string &out, unsigned long cp)
  {
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (cp >> 18));
      out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
  }

  unsigned long parse_hex4()
  {
    if (pos_ + 4 > text_.size()) fail("truncated \\u escape");
    unsigned long cp = 0;
    for (int k = 0; k < 4; ++k) {
      const char h = text_[pos_++];
      cp <<= 4;
      if (h >= '0' && h <= '9')
        cp |= static_cast<unsigned long>(h - '0');
      else if (h >= 'a' && h <= 'f')
        cp |= static_cast<unsigned long>(h - 'a' + 10);
      else if (h >= 'A' && h <= 'F')
        cp |= static_cast<unsigned long>(h - 'A' + 10);
      else
        fail("invalid \\u escape");
    }
    return cp;
  }

  std::string parse_string()
  {
    ++pos_;  // opening quote
    std::string out;
    while (true) {
      if (pos_ >= text_.size()) fail("unterminated string");
      const char c = text_[pos_++];
      if (c == '"') return out;
      if (static_cast<unsigned char>(c) < 0x20) fail("control character in string");
      if (c != '\\') {
        out += c;
        continue;
      }
      if (pos_ >= text_.size()) fail("unterminated string");
      const char e = text_[pos_++];
      switch (e) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          unsigned long cp = parse_hex4();
          if (cp >= 0xD800 && cp < 0xDC00 && consume("\\u")) {
            const unsigned long low = parse_hex4();
            if (low < 0xDC00 || low > 0xDFFF) fail("invalid surrogate pair");
            cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
          }
          append_utf8(out, cp);
          break;
        }
        default: fail(std::string("invalid escape '\\") + e + "'");
      }
    }
  }

  Value parse_array(int depth)
  {
    ++pos_;
    Value v;
    v.kind = Value::ARRAY;
    skip_space();
    if (pos_ < text_.size() && text_[pos_] == ']') {
      ++pos_;
      return v;
    }
    while (true) {
      skip_space();
      v.array.push_back(parse_value(depth + 1));
      skip_space();
      if (pos_ >= text_.size()) fail("unterminated array");
      const char c = text_[pos_++];
      if (c == ']') return v;
      if (c != ',') fail("expected ',' or ']'");
    }
  }

  Value parse_object(int depth)
  {
    ++pos_;
    Value v;
    v.kind = Value::OBJECT;
    skip_space();
    if (pos_ < text_.size() && text_[pos_] == '}') {
      ++pos_;
      return v;
    }
    while (true) {
      skip_space();
      if (pos_ >= text_.size() || text_[pos_] != '"') fail("expected a quoted key");
      std::string key = parse_string();
      if (v.find(key)) fail("duplicate key \"" + key + "\"");
      skip_space();
      if (pos_ >= text_.size() || text_[pos_++] != ':') fail("expected ':'");
      skip_space();
      Value item = parse_value(depth + 1);
      v.object.emplace_back(std::move(key), std::move(item));
      skip_space();
      if (pos_ >= text_.size()) fail("unterminated object");
      const char c = text_[pos_++];
      if (c == '}') return v;
      if (c != ',') fail("expected ',' or '}'");
    }
  }
};

inline Value parse(const std::string &text, const std::string &source)
{
  return Parser(text, source).parse_document();
}

}  // namespace json
}  // namespace geocontact

#endif
