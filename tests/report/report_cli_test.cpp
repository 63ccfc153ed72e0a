// `orpe report` end to end: on the demo's (synthetic) run and on a YCB-Video clip run, the page is
// written, every picture it references exists and is not empty, and a real browser (headless
// chromium) loads it with every image decoded. The check itself is checked: a page with a missing
// picture is caught.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "report/browser_check.h"
#include "support/cli_run.h"
#include "support/test_data.h"

namespace orpe {
namespace {

namespace fs = std::filesystem;

/// Runs `orpe report`, then checks the files and the browser. Returns the page's text.
std::string check_report(const std::string& run, const std::string& extra, size_t images) {
  const std::string log = run + ".report.log";
  EXPECT_EQ(test::run_cli("report --run " + run + " " + extra + " > " + log + " 2>&1"), 0)
      << "see " << log;
  const std::string html = run + "/report/index.html";
  EXPECT_TRUE(fs::is_regular_file(html)) << html;
  const auto srcs = test::image_sources(html);
  EXPECT_EQ(srcs.size(), images) << "4 map pictures, 2 per sampled keyframe (--keyframes)";
  for (const auto& src : srcs) {
    const fs::path p = fs::path(run) / "report" / src;
    EXPECT_TRUE(fs::is_regular_file(p)) << p;
    EXPECT_GT(fs::is_regular_file(p) ? fs::file_size(p) : 0, 100u) << p;
  }
  EXPECT_TRUE(fs::is_regular_file(run + "/report/config.json"));
  const std::string text = test::read_text(html);
  EXPECT_NE(text.find("<svg"), std::string::npos) << "charts are inline SVG";
  EXPECT_EQ(text.find("<script"), std::string::npos) << "the page needs no script";
  EXPECT_EQ(text.find("http://"), text.find("http://www.w3.org/2000/svg")) << "no network resource";
  return text;
}

void check_in_browser(const std::string& html, size_t images) {
  const test::BrowserCheck b = test::open_in_browser(html, html + ".png");
  EXPECT_EQ(b.status, 0) << "see " << b.log;
  EXPECT_EQ(b.images, static_cast<int>(images))
      << "the browser did not finish loading; see " << b.log;
  EXPECT_EQ(b.broken, "") << "images the browser could not show";
  EXPECT_TRUE(b.screenshot) << "see " << b.log;
}

// The README demo's run (scripts/demo.sh: the same scene, seed and model back-end), 6 frames
// instead of 48.
TEST(ReportCli, DemoRunGivesAPageABrowserShows) {
  const std::string dir = test::scratch_dir("demo");
  const std::string scene = dir + "/scene", run = dir + "/run";
  ASSERT_EQ(test::run_cli("synth --out " + scene +
                          " --seed 3 --frames 6 --objects 4 --scene table --width 320 --height 240 "
                          "--span-deg 9 --preview-stride 0 > " +
                          dir + "/synth.log 2>&1"),
            0);
  ASSERT_EQ(
      test::run_cli("run --dataset " + scene + " --out " + run +
                    " --mode full --set segmentation.backend=model > " + dir + "/run.log 2>&1"),
      0)
      << "see " << dir << "/run.log";
  const std::string text = check_report(run, "--keyframes 3", 4 + 3 * 2);
  for (const char* section :
       {"Camera trajectory", "ADD-S accuracy-threshold curve", "Tracking state",
        "Reconstruction error per object", "Provenance", " run --dataset "})
    EXPECT_NE(text.find(section), std::string::npos) << section;
  // A dataset that cannot be opened removes the sections that need it, with a note; the rest stays.
  const std::string moved = dir + "/moved";
  ASSERT_EQ(test::run_cli("report --run " + run + " --dataset " + dir + "/nowhere --out " + moved +
                          " > " + moved + ".log 2>&1"),
            0);
  const std::string page = test::read_text(moved + "/index.html");
  EXPECT_NE(page.find("the dataset could not be opened"), std::string::npos);
  EXPECT_EQ(test::image_sources(moved + "/index.html").size(), 4u) << "the maps, no keyframes";
  ORPE_REQUIRE_BROWSER();
  check_in_browser(run + "/report/index.html",
                   test::image_sources(run + "/report/index.html").size());
}

TEST(ReportCli, YcbVideoClipRunGivesAPageABrowserShows) {
  ORPE_REQUIRE_DATA(data, "ycbv/data/0001/000001-meta.mat");
  const std::string dir = test::scratch_dir("ycbv"), run = dir + "/run";
  ASSERT_EQ(
      test::run_cli("run --mode full --dataset " + data + "/ycbv/data/0001 --out " + run +
                    " --set dataset.last_frame=5 --set pose_registration.num_rotations=60 > " +
                    dir + "/run.log 2>&1"),
      0)
      << "see " << dir << "/run.log";
  const std::string text = check_report(run, "--keyframes 2", 4 + 2 * 2);
  EXPECT_NE(text.find("003_cracker_box"), std::string::npos) << "class names of the clip's objects";
  ORPE_REQUIRE_BROWSER();
  check_in_browser(run + "/report/index.html",
                   test::image_sources(run + "/report/index.html").size());
}

TEST(ReportCli, TheBrowserCheckCatchesAMissingPicture) {
  ORPE_REQUIRE_BROWSER();
  const std::string dir = test::scratch_dir("page");
  std::ofstream(dir + "/index.html") << "<!DOCTYPE html><html><head><title>t</title></head><body>"
                                        "<img src=\"nothing_here.png\"></body></html>";
  const test::BrowserCheck b = test::open_in_browser(dir + "/index.html", dir + "/shot.png");
  EXPECT_EQ(b.images, 1);
  EXPECT_EQ(b.broken, "nothing_here.png");
}

TEST(ReportCli, TheScriptsReportPageConvertsTablesAndDrawsCharts) {
  if (std::system("/usr/bin/python3 -c '' 2> /dev/null") != 0)
    GTEST_SKIP() << "no /usr/bin/python3";
  const std::string dir = test::scratch_dir("page");
  const std::string scripts = std::string(ORPE_SOURCE_DIR) + "/scripts";
  ASSERT_EQ(std::system(("/usr/bin/python3 " + scripts + "/report_page.py --selftest > " + dir +
                         "/log 2>&1")
                            .c_str()),
            0)
      << test::read_text(dir + "/log");
  const std::string page = dir + "/report.html";
  const std::string code = "import sys; sys.path.insert(0, '" + scripts +
                           "'); import report_page as r; "
                           "r.write('" +
                           page +
                           "', 't', '| a | b |\\n| --- | --- |\\n| x | 1.5 |\\n', "
                           "[r.bar_chart('c', ['g'], {'s': [1.0]}, 'v')], [('run', '" +
                           dir + "/run/report/index.html')])";
  ASSERT_EQ(std::system(("/usr/bin/python3 -c \"" + code + "\" >> " + dir + "/log 2>&1").c_str()),
            0)
      << test::read_text(dir + "/log");
  const std::string text = test::read_text(page);
  EXPECT_NE(text.find("<td class=\"num\">1.5</td>"), std::string::npos) << text;
  EXPECT_NE(text.find("<svg"), std::string::npos);
  EXPECT_NE(text.find("href=\"run/report/index.html\""), std::string::npos)
      << "links relative to the page";
}

TEST(ReportCli, ANonRunFolderIsRefusedNamingTheFile) {
  const std::string dir = test::scratch_dir("empty");
  const std::string log = dir + "/log";
  EXPECT_EQ(test::run_cli("report --run " + dir + " 2> " + log) >> 8, 2);
  EXPECT_NE(test::read_text(log).find("summary.json"), std::string::npos) << test::read_text(log);
}

}  // namespace
}  // namespace orpe
