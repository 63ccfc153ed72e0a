// Opening an HTML page in a real browser (Debian's chromium, headless) from a test: whether it
// loads, and whether every <img> it has decoded (complete, natural width > 0), as the browser saw
// it.
//
// The page itself has no script; the check loads a copy of it with one appended script that, after
// the load event, writes the number of images and the broken ones into the title, read back with
// --dump-dom. A screenshot of the page proper is taken too. Chromium absent: available = false
// (tests skip, unless ORPE_REQUIRE_BROWSER=1, set by .ci/run, where that is a failure).
#pragma once

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

namespace orpe::test {

inline std::string chromium_binary() {
  if (const char* env = std::getenv("ORPE_CHROMIUM"); env && *env) return env;
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (std::filesystem::exists(p)) return p;
  return {};
}

inline bool browser_required() {
  const char* env = std::getenv("ORPE_REQUIRE_BROWSER");
  return env && std::string(env) == "1";
}

/// Skips the test when chromium is absent (fails when ORPE_REQUIRE_BROWSER=1).
#define ORPE_REQUIRE_BROWSER()                                                                 \
  do {                                                                                         \
    if (::orpe::test::chromium_binary().empty()) {                                             \
      if (::orpe::test::browser_required())                                                    \
        FAIL() << "chromium is not installed (ORPE_REQUIRE_BROWSER=1): "                       \
                  "apt-get install chromium, or bash scripts/install-deps.sh";                 \
      GTEST_SKIP() << "chromium is not installed (bash scripts/install-deps.sh installs it): " \
                      "the page is not opened in a browser";                                   \
    }                                                                                          \
  } while (0)

struct BrowserCheck {
  int status = -1;          ///< of the --dump-dom run (0 = the page loaded)
  int images = -1;          ///< <img> elements the browser found
  std::string broken;       ///< srcs of images that did not decode, space-separated
  bool screenshot = false;  ///< the screenshot was written and is not empty
  std::string log;          ///< where chromium's output went
};

inline std::string read_text(const std::string& path) {
  std::ifstream is(path);
  std::stringstream ss;
  ss << is.rdbuf();
  return ss.str();
}

/// Reads "<title>CHECK images=N broken=M SRC...</title>" (written by the probe script) into `r`;
/// leaves `r.images` at -1 when the title is not there. Plain string search: std::regex here made
/// g++ 12 report a false -Wmaybe-uninitialized inside <regex> in the asan preset (-O1).
inline void parse_check_title(const std::string& dom, BrowserCheck& r) {
  const std::string head = "<title>CHECK images=";
  const size_t at = dom.find(head);
  if (at == std::string::npos) return;
  const size_t end = dom.find("</title>", at);
  if (end == std::string::npos) return;
  std::istringstream title(dom.substr(at + head.size(), end - at - head.size()));
  int images = -1, broken = -1;
  std::string word;
  if (!(title >> images) || !(title >> word) || word.rfind("broken=", 0) != 0) return;
  try {
    broken = std::stoi(word.substr(7));
  } catch (const std::exception&) {
    return;
  }
  if (images < 0 || broken < 0) return;
  r.images = images;
  r.broken.clear();
  while (title >> word) r.broken += (r.broken.empty() ? "" : " ") + word;
}

/// Opens `html` (a file) in headless chromium; `screenshot_png` receives a picture of the page.
inline BrowserCheck open_in_browser(const std::string& html, const std::string& screenshot_png) {
  namespace fs = std::filesystem;
  BrowserCheck r;
  const fs::path page = fs::absolute(html);
  const fs::path probe = page.parent_path() / (".browser_check_" + page.filename().string());
  std::string text = read_text(page.string());
  const std::string script =
      "<script>window.addEventListener('load',()=>{const b=[...document.images].filter(i=>!("
      "i.complete&&i.naturalWidth>0)).map(i=>i.getAttribute('src'));document.title='CHECK images='"
      "+document.images.length+' broken='+b.length+' '+b.join(' ');});</script>";
  const size_t end = text.rfind("</body>");
  text.insert(end == std::string::npos ? text.size() : end, script);
  std::ofstream(probe) << text;
  const std::string flags = " --headless --no-sandbox --disable-gpu --hide-scrollbars ";
  r.log = page.string() + ".browser.log";
  const std::string dom = page.string() + ".dom.html";
  r.status = std::system(("timeout 120 " + chromium_binary() + flags + "--dump-dom 'file://" +
                          probe.string() + "' > '" + dom + "' 2> '" + r.log + "'")
                             .c_str());
  fs::remove(probe);
  parse_check_title(read_text(dom), r);
  [[maybe_unused]] const int shot = std::system(
      ("timeout 120 " + chromium_binary() + flags + "--window-size=1400,2400 --screenshot='" +
       screenshot_png + "' 'file://" + page.string() + "' >> '" + r.log + "' 2>&1")
          .c_str());
  r.screenshot = fs::exists(screenshot_png) && fs::file_size(screenshot_png) > 0;
  return r;
}

/// The src="..." of every <img> in an HTML file (a non-empty src attribute after white space,
/// inside the tag).
inline std::set<std::string> image_sources(const std::string& html) {
  std::set<std::string> srcs;
  const std::string text = read_text(html);
  for (size_t tag = text.find("<img"); tag != std::string::npos; tag = text.find("<img", tag + 4)) {
    const size_t close = std::min(text.find('>', tag), text.size());
    for (size_t a = text.find("src=\"", tag); a != std::string::npos && a < close;
         a = text.find("src=\"", a + 1)) {
      if (!std::isspace(static_cast<unsigned char>(text[a - 1]))) continue;
      const size_t end = text.find('"', a + 5);
      if (end != std::string::npos && end > a + 5) srcs.insert(text.substr(a + 5, end - a - 5));
      break;
    }
  }
  return srcs;
}

}  // namespace orpe::test
