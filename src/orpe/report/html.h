// Building blocks of the report's HTML page: escaping, tables, sections and the page itself with
// an inline style sheet (no script, no external resource; images are files beside the page).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace orpe::report {

/// Text made safe for HTML content and attribute values (& < > " ').
std::string html_escape(std::string_view text);

/// A table; cells are HTML (escape text with html_escape). Numeric-looking cells are right-aligned.
struct HtmlTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::string caption;  ///< text, escaped on output
  std::string html() const;
};

/// <figure> with an image file (relative to the page) and a caption (text).
std::string html_image(const std::string& src, const std::string& caption, int width_px = 0);

/// A page: a title, then sections in order, each an <h2> heading and HTML body.
class HtmlPage {
 public:
  explicit HtmlPage(std::string title) : title_(std::move(title)) {}
  void add_section(const std::string& heading, const std::string& body_html);
  /// The whole document (<!DOCTYPE html> ... </html>), with a table of contents.
  std::string html() const;

 private:
  std::string title_;
  std::vector<std::pair<std::string, std::string>> sections_;
};

}  // namespace orpe::report
