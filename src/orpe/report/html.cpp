#include "orpe/report/html.h"

#include <fmt/format.h>

#include <cctype>

namespace orpe::report {
namespace {

bool numeric_cell(const std::string& cell) {
  if (cell.empty()) return false;
  for (char c : cell)
    if (!std::isdigit(static_cast<unsigned char>(c)) && c != '.' && c != '-' && c != '+' &&
        c != '%' && c != ' ' && c != 'e')
      return false;
  return std::isdigit(static_cast<unsigned char>(cell.front())) || cell.front() == '-';
}

std::string anchor(size_t i) {
  return fmt::format("s{}", i + 1);
}

constexpr const char* kStyle = R"(
body{font-family:sans-serif;margin:1.5em auto;max-width:1400px;padding:0 1em;color:#222}
h1{font-size:1.6em} h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}
th,td{border:1px solid #ccc;padding:.25em .6em;vertical-align:top}
th{background:#f2f2f2} td.num{text-align:right;font-variant-numeric:tabular-nums}
caption{caption-side:top;text-align:left;font-weight:bold;padding:.3em 0}
figure{display:inline-block;margin:.4em .8em .8em 0;vertical-align:top}
figure img{max-width:100%;border:1px solid #ccc}
figcaption{font-size:.88em;color:#444;max-width:660px}
.row{display:flex;flex-wrap:wrap;gap:.8em;align-items:flex-start}
.overlay{position:relative;display:inline-block}
.overlay svg{position:absolute;left:0;top:0}
.swatch{display:inline-block;width:.9em;height:.9em;margin-right:.3em;vertical-align:middle;border:1px solid #555}
pre{background:#f6f6f6;padding:.6em;overflow-x:auto;font-size:.85em}
.note{color:#555;font-size:.9em}
)";

}  // namespace

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) switch (c) {
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
        out += "&#39;";
        break;
      default:
        out += c;
    }
  return out;
}

std::string HtmlTable::html() const {
  std::string s = "<table>";
  if (!caption.empty()) s += "<caption>" + html_escape(caption) + "</caption>";
  s += "\n<tr>";
  for (const auto& h : header) s += "<th>" + h + "</th>";
  s += "</tr>\n";
  for (const auto& row : rows) {
    s += "<tr>";
    for (const auto& cell : row)
      s += (numeric_cell(cell) ? "<td class=\"num\">" : "<td>") + cell + "</td>";
    s += "</tr>\n";
  }
  return s + "</table>\n";
}

std::string html_image(const std::string& src, const std::string& caption, int width_px) {
  return fmt::format("<figure><img src=\"{}\" alt=\"{}\"{}><figcaption>{}</figcaption></figure>\n",
                     html_escape(src), html_escape(caption),
                     width_px > 0 ? fmt::format(" width=\"{}\"", width_px) : std::string(),
                     html_escape(caption));
}

void HtmlPage::add_section(const std::string& heading, const std::string& body_html) {
  sections_.emplace_back(heading, body_html);
}

std::string HtmlPage::html() const {
  std::string s = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{0}</title>\n"
      "<style>{1}</style>\n</head>\n<body>\n<h1>{0}</h1>\n<nav><ul>\n",
      html_escape(title_), kStyle);
  for (size_t i = 0; i < sections_.size(); ++i)
    s += fmt::format("<li><a href=\"#{}\">{}</a></li>\n", anchor(i),
                     html_escape(sections_[i].first));
  s += "</ul></nav>\n";
  for (size_t i = 0; i < sections_.size(); ++i)
    s += fmt::format("<section id=\"{}\">\n<h2>{}</h2>\n{}</section>\n", anchor(i),
                     html_escape(sections_[i].first), sections_[i].second);
  return s + "</body>\n</html>\n";
}

}  // namespace orpe::report
