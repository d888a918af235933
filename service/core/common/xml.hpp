// XML text and attribute escaping for the writers that emit XML (VTU files, SVG charts).
#pragma once

#include <string>
#include <string_view>

namespace tc {

/// Escapes the five XML special characters (& < > " ') of a text or attribute value.
inline std::string xml_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace tc
