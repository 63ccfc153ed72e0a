// Opening an HTML page in a real browser (Debian's chromium, headless) from a test: whether it
// loads, and whether every <img> it has decoded (complete, natural width > 0), as the browser saw
// it.
//
// The page itself has no script; the check loads a copy of it with one appended script that, after
// the load event, writes the number of images and the broken ones into the title, read back with
// --dump-dom. A screenshot of the page proper is taken too. Chromium absent: available = false
// (tests skip, unless ORPE_REQUIRE_BROWSER=1, set by .ci/run, where that is a failure).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
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
  std::smatch m;
  const std::string out = read_text(dom);
  if (std::regex_search(out, m,
                        std::regex("<title>CHECK images=(\\d+) broken=(\\d+) ?([^<]*)</title>")))
    r.images = std::stoi(m[1]), r.broken = m[3];
  [[maybe_unused]] const int shot = std::system(
      ("timeout 120 " + chromium_binary() + flags + "--window-size=1400,2400 --screenshot='" +
       screenshot_png + "' 'file://" + page.string() + "' >> '" + r.log + "' 2>&1")
          .c_str());
  r.screenshot = fs::exists(screenshot_png) && fs::file_size(screenshot_png) > 0;
  return r;
}

/// The src="..." of every <img> in an HTML file.
inline std::set<std::string> image_sources(const std::string& html) {
  std::set<std::string> srcs;
  const std::string text = read_text(html);
  const std::regex img("<img[^>]*\\ssrc=\"([^\"]+)\"");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), img); it != std::sregex_iterator();
       ++it)
    srcs.insert((*it)[1]);
  return srcs;
}

}  // namespace orpe::test
