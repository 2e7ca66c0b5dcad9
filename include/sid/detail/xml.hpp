#pragma once
/// @file
/// @brief The little XML a robot description needs: elements, attributes, nesting and the text
/// directly inside an element (`<mechanicalReduction>50</mechanicalReduction>`). Namespaces and
/// DTDs are not interpreted (a prefixed name such as `xacro:include` is just a name); a UTF-8
/// byte order mark, declarations, comments, processing instructions and a DOCTYPE with or
/// without an internal subset are skipped, CDATA is kept as text as written. Attribute values
/// may be quoted either way and hold the five predefined entities and character references
/// (`&#233;`, `&#xE9;`, written as UTF-8); entities a DTD declares are refused by name there,
/// and kept as written in text. Elements may nest at
/// most kMaxXmlDepth deep, so that a hostile document cannot overflow the stack of the recursive
/// reader.

#include <cctype>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid::detail {

/// How deep elements may nest (the root is at depth 1); a robot description needs about 4.
inline constexpr int kMaxXmlDepth = 256;

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes;
  std::vector<XmlElement> children;
  /// The character data directly inside the element (around its children, joined, references
  /// decoded), whitespace included.
  std::string text;

  const std::string* attribute(const std::string& key) const {
    for (const auto& [k, v] : attributes)
      if (k == key) return &v;
    return nullptr;
  }
  const XmlElement* child(const std::string& child_name) const {
    for (const auto& c : children)
      if (c.name == child_name) return &c;
    return nullptr;
  }
};

/// Reads one document. The parser keeps its own copy of the text, so a temporary may be given.
class XmlParser {
 public:
  /// @param who the name messages start with, e.g. "sid::chain_from_urdf".
  XmlParser(std::string text, std::string who) : text_(std::move(text)), who_(std::move(who)) {}

  /// @throws std::invalid_argument naming the line of the first problem.
  XmlElement parse_document() {
    if (starts_with("\xEF\xBB\xBF")) pos_ = 3;  // the UTF-8 byte order mark
    skip_misc();
    if (at_end() || text_[pos_] != '<') fail("no root element");
    XmlElement root = parse_element(1);
    skip_misc();
    if (!at_end()) fail("text after the root element");
    return root;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    int line = 1;
    for (std::size_t i = 0; i < pos_ && i < text_.size(); ++i) line += text_[i] == '\n';
    throw std::invalid_argument(who_ + ": line " + std::to_string(line) + ": " + what);
  }

  bool at_end() const { return pos_ >= text_.size(); }
  bool starts_with(const char* s) const {
    return text_.compare(pos_, std::char_traits<char>::length(s), s) == 0;
  }

  void skip_space() {
    while (!at_end() && (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\n' ||
                         text_[pos_] == '\r'))
      ++pos_;
  }

  void skip_past(const char* end, const char* what) {
    const std::size_t found = text_.find(end, pos_);
    if (found == std::string::npos) fail(std::string("unterminated ") + what);
    pos_ = found + std::char_traits<char>::length(end);
  }

  // Whitespace, comments, declarations and DOCTYPE between elements.
  void skip_misc() {
    for (;;) {
      skip_space();
      if (starts_with("<!--"))
        skip_past("-->", "comment");
      else if (starts_with("<?"))
        skip_past("?>", "declaration");
      else if (starts_with("<!"))
        skip_doctype();
      else
        return;
    }
  }

  // <!DOCTYPE ...>, whose internal subset [...] may hold '>' in declarations, quoted literals
  // and comments.
  void skip_doctype() {
    const std::size_t start = pos_;
    pos_ += 2;
    int brackets = 0;
    while (!at_end()) {
      if (starts_with("<!--")) {
        skip_past("-->", "comment");
        continue;
      }
      const char c = text_[pos_++];
      if (c == '"' || c == '\'') {
        const std::size_t close = text_.find(c, pos_);
        if (close == std::string::npos) break;
        pos_ = close + 1;
      } else if (c == '[') {
        ++brackets;
      } else if (c == ']') {
        --brackets;
      } else if (c == '>' && brackets <= 0) {
        return;
      }
    }
    pos_ = start;
    fail("unterminated DOCTYPE");
  }

  std::string parse_name() {
    const std::size_t start = pos_;
    // Bytes from 0x80 are the UTF-8 of letters XML allows in names beyond ASCII.
    while (!at_end() && (std::isalnum(static_cast<unsigned char>(text_[pos_])) ||
                         text_[pos_] == '_' || text_[pos_] == '-' || text_[pos_] == '.' ||
                         text_[pos_] == ':' || static_cast<unsigned char>(text_[pos_]) >= 0x80))
      ++pos_;
    if (pos_ == start) fail("expected a name");
    return text_.substr(start, pos_ - start);
  }

  std::string parse_value() {
    if (at_end() || (text_[pos_] != '"' && text_[pos_] != '\'')) fail("expected a quoted value");
    const char quote = text_[pos_++];
    std::string value;
    while (!at_end() && text_[pos_] != quote) {
      if (text_[pos_] == '&') {
        parse_reference(value);
      } else {
        value += text_[pos_++];
      }
    }
    if (at_end()) fail("unterminated attribute value");
    ++pos_;
    return value;
  }

  // An entity or character reference at '&', appended to value.
  void parse_reference(std::string& value) {
    const std::string problem = read_reference(value);
    if (!problem.empty()) fail(problem);
  }

  // An entity or character reference at '&', appended to value and passed; or what is wrong
  // with it, with nothing appended or passed.
  std::string read_reference(std::string& value) {
    const std::size_t semicolon = text_.find(';', pos_);
    const std::size_t length = semicolon == std::string::npos ? 0 : semicolon + 1 - pos_;
    if (length < 3 || length > 12) return "'&' that starts no entity in an attribute value";
    const std::string reference = text_.substr(pos_, length);
    if (reference[1] == '#') {
      const bool hex = reference[2] == 'x';
      const std::string digits = reference.substr(hex ? 3 : 2, length - (hex ? 4 : 3));
      unsigned long code = 0;  // at most 9 decimal or 8 hex digits: no overflow
      for (const char d : digits) {
        const auto u = static_cast<unsigned char>(d);
        if (!(hex ? std::isxdigit(u) : std::isdigit(u))) {
          code = 0;
          break;
        }
        code = code * (hex ? 16 : 10) +
               static_cast<unsigned long>(std::isdigit(u) ? d - '0' : std::tolower(u) - 'a' + 10);
      }
      if (digits.empty() || code == 0 || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF))
        return "character reference " + reference + " is not a character";
      append_utf8(code, value);
    } else {
      static const std::pair<const char*, char> entities[] = {
          {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
      bool known = false;
      for (const auto& [entity, c] : entities)
        if (reference == entity) {
          value += c;
          known = true;
        }
      if (!known)
        return "unknown entity " + reference +
               " in an attribute value (entities a DTD declares are not read)";
    }
    pos_ += length;
    return "";
  }

  static void append_utf8(unsigned long code, std::string& out) {
    const auto byte = [&](unsigned long b) { out += static_cast<char>(b); };
    if (code < 0x80) {
      byte(code);
    } else if (code < 0x800) {
      byte(0xC0 | (code >> 6));
      byte(0x80 | (code & 0x3F));
    } else if (code < 0x10000) {
      byte(0xE0 | (code >> 12));
      byte(0x80 | ((code >> 6) & 0x3F));
      byte(0x80 | (code & 0x3F));
    } else {
      byte(0xF0 | (code >> 18));
      byte(0x80 | ((code >> 12) & 0x3F));
      byte(0x80 | ((code >> 6) & 0x3F));
      byte(0x80 | (code & 0x3F));
    }
  }

  XmlElement parse_element(int depth) {
    if (depth > kMaxXmlDepth) fail("elements nested deeper than " + std::to_string(kMaxXmlDepth));
    XmlElement e;
    ++pos_;  // '<'
    e.name = parse_name();
    for (;;) {
      skip_space();
      if (at_end()) fail("unterminated element <" + e.name + ">");
      if (starts_with("/>")) {
        pos_ += 2;
        return e;
      }
      if (text_[pos_] == '>') {
        ++pos_;
        break;
      }
      std::string key = parse_name();
      skip_space();
      if (at_end() || text_[pos_] != '=') fail("expected '=' after attribute " + key);
      ++pos_;
      skip_space();
      if (e.attribute(key)) fail("attribute " + key + " given twice in <" + e.name + ">");
      e.attributes.emplace_back(std::move(key), parse_value());
    }
    for (;;) {
      const std::size_t text_end = text_.find('<', pos_);
      if (text_end == std::string::npos) fail("element <" + e.name + "> is not closed");
      while (pos_ < text_end) {
        if (text_[pos_] != '&' || !read_reference(e.text).empty()) e.text += text_[pos_++];
      }
      pos_ = text_end;
      if (starts_with("<!--")) {
        skip_past("-->", "comment");
      } else if (starts_with("<![CDATA[")) {
        const std::size_t start = pos_ + 9;
        skip_past("]]>", "CDATA section");
        e.text.append(text_, start, pos_ - 3 - start);
      } else if (starts_with("<?")) {
        skip_past("?>", "processing instruction");
      } else if (starts_with("</")) {
        pos_ += 2;
        const std::string closing = parse_name();
        if (closing != e.name) fail("</" + closing + "> closes <" + e.name + ">");
        skip_space();
        if (at_end() || text_[pos_] != '>') fail("expected '>' after </" + closing);
        ++pos_;
        return e;
      } else {
        e.children.push_back(parse_element(depth + 1));
      }
    }
  }

  std::string text_;
  std::string who_;
  std::size_t pos_ = 0;
};

}  // namespace sid::detail
