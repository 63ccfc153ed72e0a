#include "orpe/synth/textures.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

namespace orpe::synth {
namespace {

// Images are drawn in cv::Mat with channels in R, G, B order (never shown to OpenCV's BGR I/O).
cv::Scalar sc(Rgb8 c) {
  return cv::Scalar(c.r, c.g, c.b);
}

ColorImage to_image(const cv::Mat& m) {
  ColorImage out(m.cols, m.rows);
  for (int v = 0; v < m.rows; ++v) {
    const cv::Vec3b* row = m.ptr<cv::Vec3b>(v);
    for (int u = 0; u < m.cols; ++u) out.at(u, v) = {row[u][0], row[u][1], row[u][2]};
  }
  return out;
}

/// Smooth value noise in [-1, 1] (sum of octaves of bicubically upsampled random grids).
cv::Mat value_noise(int w, int h, double feature_px, int octaves, std::mt19937_64& rng) {
  cv::Mat acc(h, w, CV_32F, cv::Scalar(0));
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  double amp = 1.0, total = 0.0, f = feature_px;
  for (int o = 0; o < octaves; ++o) {
    const int gw = std::max(2, static_cast<int>(w / f) + 2),
              gh = std::max(2, static_cast<int>(h / f) + 2);
    cv::Mat g(gh, gw, CV_32F);
    for (int y = 0; y < gh; ++y)
      for (int x = 0; x < gw; ++x) g.at<float>(y, x) = U(rng);
    cv::Mat up;
    cv::resize(g, up, cv::Size(w, h), 0, 0, cv::INTER_CUBIC);
    acc += up * amp;
    total += amp;
    amp *= 0.5;
    f *= 0.5;
    if (f < 1.5) break;
  }
  return acc / total;
}

/// Adds per-pixel grain and low-frequency blotches (printing on board is never perfectly flat).
void add_grain(cv::Mat& img, double blotch, double grain, std::mt19937_64& rng) {
  const cv::Mat low = value_noise(img.cols, img.rows, std::max(8.0, img.cols / 6.0), 3, rng);
  std::normal_distribution<float> N(0.0f, 1.0f);
  for (int v = 0; v < img.rows; ++v) {
    cv::Vec3b* row = img.ptr<cv::Vec3b>(v);
    const float* lo = low.ptr<float>(v);
    for (int u = 0; u < img.cols; ++u) {
      const float k = 1.0f + static_cast<float>(blotch) * lo[u];
      const float g = static_cast<float>(grain) * N(rng);
      for (int c = 0; c < 3; ++c) row[u][c] = cv::saturate_cast<uchar>(row[u][c] * k + g);
    }
  }
}

std::string random_word(std::mt19937_64& rng, int min_len, int max_len, bool upper) {
  static const char* kLetters = "ABCDEFGHIJKLMNOPRSTUVEAIOEA";
  std::uniform_int_distribution<int> L(min_len, max_len), C(0, 26);
  std::string w;
  const int n = L(rng);
  for (int i = 0; i < n; ++i) {
    char ch = kLetters[C(rng)];
    if (!upper && i > 0) ch = static_cast<char>(std::tolower(ch));
    w.push_back(ch);
  }
  return w;
}

/// Lines of random words filling the box (x, y, w, h), font scaled to `line_px` height.
void draw_text_block(cv::Mat& img, cv::Rect box, int line_px, Rgb8 ink, std::mt19937_64& rng,
                     bool upper = false) {
  line_px = std::max(line_px, 5);
  const double scale = line_px / 30.0;  // Hershey simplex: ~22 px cap height at scale 1
  const int thickness = std::max(1, static_cast<int>(std::round(line_px / 14.0)));
  for (int y = box.y + line_px; y <= box.y + box.height; y += static_cast<int>(line_px * 1.5)) {
    int x = box.x;
    while (x < box.x + box.width) {
      const std::string w = random_word(rng, 2, 8, upper);
      int base = 0;
      const cv::Size sz = cv::getTextSize(w, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &base);
      if (x + sz.width > box.x + box.width) break;
      cv::putText(img, w, cv::Point(x, y), cv::FONT_HERSHEY_SIMPLEX, scale, sc(ink), thickness,
                  cv::LINE_AA);
      x += sz.width + std::max(3, line_px / 2);
    }
  }
}

void draw_logo(cv::Mat& img, cv::Point c, int r, const PrintStyle& s, std::mt19937_64& rng) {
  r = std::max(r, 4);
  switch (s.logo_shape % 4) {
    case 0:
      cv::circle(img, c, r, sc(s.primary), cv::FILLED, cv::LINE_AA);
      cv::circle(img, c, r * 2 / 3, sc(s.secondary), cv::FILLED, cv::LINE_AA);
      cv::circle(img, c + cv::Point(r / 5, -r / 6), r / 3, sc(s.primary), cv::FILLED, cv::LINE_AA);
      break;
    case 1: {
      std::vector<cv::Point> pts{{c.x, c.y - r}, {c.x + r, c.y}, {c.x, c.y + r}, {c.x - r, c.y}};
      cv::fillConvexPoly(img, pts, sc(s.primary), cv::LINE_AA);
      cv::circle(img, c, r / 3, sc(s.secondary), cv::FILLED, cv::LINE_AA);
      break;
    }
    case 2: {
      std::vector<cv::Point> pts;
      for (int k = 0; k < 10; ++k) {
        const double a = -M_PI / 2 + k * M_PI / 5;
        const double rr = (k % 2 == 0) ? r : r * 0.45;
        pts.emplace_back(c.x + static_cast<int>(rr * std::cos(a)),
                         c.y + static_cast<int>(rr * std::sin(a)));
      }
      cv::fillPoly(img, std::vector<std::vector<cv::Point>>{pts}, sc(s.secondary), cv::LINE_AA);
      cv::polylines(img, pts, true, sc(s.primary), std::max(1, r / 10), cv::LINE_AA);
      break;
    }
    default: {
      cv::rectangle(img, cv::Rect(c.x - r, c.y - r, 2 * r, 2 * r), sc(s.primary), cv::FILLED,
                    cv::LINE_AA);
      cv::rectangle(img, cv::Rect(c.x - r / 2, c.y - r / 2, r, r), sc(s.secondary), cv::FILLED,
                    cv::LINE_AA);
      break;
    }
  }
  // A brand "word" under or over the logo.
  const std::string w = random_word(rng, 3, 6, true);
  const double scale = r / 30.0;
  const int th = std::max(1, r / 12);
  int base = 0;
  const cv::Size sz = cv::getTextSize(w, cv::FONT_HERSHEY_DUPLEX, scale, th, &base);
  cv::putText(img, w, cv::Point(c.x - sz.width / 2, c.y + r + sz.height + r / 5),
              cv::FONT_HERSHEY_DUPLEX, scale, sc(s.ink), th, cv::LINE_AA);
}

void draw_barcode(cv::Mat& img, cv::Rect box, std::mt19937_64& rng) {
  cv::rectangle(img, box, cv::Scalar(250, 250, 250), cv::FILLED);
  std::uniform_int_distribution<int> Wd(1, 3);
  const int unit = std::max(1, box.width / 60);
  int x = box.x + 2 * unit;
  bool black = true;
  while (x < box.x + box.width - 2 * unit) {
    const int w = Wd(rng) * unit;
    if (black)
      cv::rectangle(img, cv::Rect(x, box.y + 2, w, box.height - 4), cv::Scalar(10, 10, 10),
                    cv::FILLED);
    x += w;
    black = !black;
  }
}

Rgb8 hsv(double h, double s, double v) {
  const double c = v * s, x = c * (1 - std::abs(std::fmod(h / 60.0, 2) - 1)), m = v - c;
  double r = 0, g = 0, b = 0;
  if (h < 60)
    r = c, g = x;
  else if (h < 120)
    r = x, g = c;
  else if (h < 180)
    g = c, b = x;
  else if (h < 240)
    g = x, b = c;
  else if (h < 300)
    r = x, b = c;
  else
    r = c, b = x;
  auto q = [](double t) {
    return static_cast<std::uint8_t>(std::clamp(t * 255.0 + 0.5, 0.0, 255.0));
  };
  return {q(r + m), q(g + m), q(b + m)};
}

}  // namespace

PrintStyle random_print_style(std::mt19937_64& rng, bool cardboard) {
  std::uniform_real_distribution<double> U(0, 1);
  PrintStyle s;
  const double h1 = 360 * U(rng);
  const double h2 = std::fmod(h1 + 90 + 180 * U(rng), 360.0);
  s.primary = hsv(h1, 0.65 + 0.3 * U(rng), 0.55 + 0.4 * U(rng));
  s.secondary = hsv(h2, 0.5 + 0.4 * U(rng), 0.75 + 0.25 * U(rng));
  s.cardboard = cardboard;
  if (cardboard) {
    s.background = hsv(28 + 8 * U(rng), 0.45 + 0.1 * U(rng), 0.62 + 0.1 * U(rng));
    s.ink = hsv(0, 0, 0.1 + 0.1 * U(rng));
  } else {
    const bool dark_bg = U(rng) < 0.3;
    s.background = dark_bg ? hsv(360 * U(rng), 0.6, 0.25 + 0.15 * U(rng))
                           : hsv(40 + 20 * U(rng), 0.05 + 0.1 * U(rng), 0.9);
    s.ink = dark_bg ? Rgb8{245, 245, 240} : hsv(0, 0, 0.12);
  }
  s.logo_shape = static_cast<int>(U(rng) * 4);
  s.seed = rng();
  return s;
}

ColorImage draw_package_face(int w, int h, const PrintStyle& s, int role, int variant) {
  w = std::max(w, 8), h = std::max(h, 8);
  std::mt19937_64 rng(s.seed * 31 + static_cast<std::uint64_t>(role) * 7919 +
                      static_cast<std::uint64_t>(variant));
  std::uniform_real_distribution<double> U(0, 1);
  cv::Mat img(h, w, CV_8UC3, sc(s.background));
  const int m = std::max(2, std::min(w, h) / 20);  // margin
  if (role == 3) {
    // Flaps: a seam across the middle with a strip of tape, a small printed arrow mark.
    const bool along_x = w >= h;
    const int tape = std::max(3, (along_x ? h : w) / 6);
    cv::Rect strip =
        along_x ? cv::Rect(0, h / 2 - tape / 2, w, tape) : cv::Rect(w / 2 - tape / 2, 0, tape, h);
    cv::rectangle(img, strip, s.cardboard ? cv::Scalar(215, 180, 120) : sc(s.secondary),
                  cv::FILLED);
    if (along_x)
      cv::line(img, {0, h / 2}, {w, h / 2}, cv::Scalar(90, 70, 50), 1, cv::LINE_AA);
    else
      cv::line(img, {w / 2, 0}, {w / 2, h}, cv::Scalar(90, 70, 50), 1, cv::LINE_AA);
    const int r = std::min(w, h) / 7;
    const cv::Point c(w / 5 + variant * 3, h / 5 + r);
    cv::arrowedLine(img, c + cv::Point(0, r), c - cv::Point(0, r), sc(s.ink), std::max(1, r / 5),
                    cv::LINE_AA, 0, 0.4);
    draw_text_block(img, cv::Rect(w / 2 + m, m, w / 2 - 2 * m, h / 4), std::max(5, h / 18), s.ink,
                    rng, true);
  } else if (s.cardboard) {
    // Shipping carton: mostly bare board, a printed label area, a logo, handling marks.
    const int band = std::max(3, h / 9);
    cv::rectangle(img, cv::Rect(0, h - band - m, w, band), sc(s.primary), cv::FILLED);
    const int r = std::max(6, std::min(w, h) / (role == 0 ? 5 : 7));
    draw_logo(img, cv::Point(role == 0 ? w / 4 : 3 * w / 4, h / 3), r, s, rng);
    cv::Rect label(w / 2 + m, m * 2, w / 2 - 3 * m, h / 2 - 2 * m);
    if (role != 0) label = cv::Rect(m * 2, h / 2, w / 2, h / 3);
    cv::rectangle(img, label, cv::Scalar(245, 245, 240), cv::FILLED);
    draw_text_block(img,
                    cv::Rect(label.x + m, label.y + m / 2, label.width - 2 * m, label.height / 2),
                    std::max(5, label.height / 8), s.ink, rng, true);
    draw_barcode(img,
                 cv::Rect(label.x + m, label.y + label.height * 2 / 3, label.width * 2 / 3,
                          label.height / 4),
                 rng);
  } else {
    // Retail package: colour bands, big logo, text lines, a product "window".
    const int nb = 1 + static_cast<int>(U(rng) * 3);
    for (int b = 0; b < nb; ++b) {
      const int y = static_cast<int>(h * (0.1 + 0.8 * U(rng)));
      const int t = std::max(2, static_cast<int>(h * (0.03 + 0.12 * U(rng))));
      cv::rectangle(img, cv::Rect(0, y, w, t), sc(b % 2 ? s.secondary : s.primary), cv::FILLED);
    }
    if (role == 0) {
      const int r = std::max(6, std::min(w, h) / 4);
      draw_logo(img, cv::Point(w / 2 + static_cast<int>((U(rng) - 0.5) * w / 4), h / 3), r, s, rng);
      cv::ellipse(img, cv::Point(w / 2, h * 3 / 4), cv::Size(w / 4, h / 10), 0, 0, 360,
                  sc(s.secondary), cv::FILLED, cv::LINE_AA);
      draw_text_block(img, cv::Rect(m, h * 5 / 6, w - 2 * m, h / 6 - m), std::max(5, h / 22), s.ink,
                      rng, true);
    } else if (role == 1) {
      draw_text_block(img, cv::Rect(m, m, w / 2 - 2 * m, h * 2 / 3), std::max(5, h / 28), s.ink,
                      rng);
      draw_text_block(img, cv::Rect(w / 2 + m, m, w / 2 - 2 * m, h / 2), std::max(5, h / 28), s.ink,
                      rng);
      draw_barcode(img, cv::Rect(w / 2 + m, h * 3 / 4, w / 3, h / 6), rng);
      draw_logo(img, cv::Point(w * 3 / 4, h * 3 / 5), std::max(5, std::min(w, h) / 10), s, rng);
    } else {
      const int r = std::max(5, std::min(w, h) / 4);
      draw_logo(img, cv::Point(w / 2, h / 4), r, s, rng);
      draw_text_block(img, cv::Rect(m, h / 2, w - 2 * m, h / 2 - m), std::max(5, w / 10), s.ink,
                      rng);
    }
  }
  add_grain(img, s.cardboard ? 0.08 : 0.03, s.cardboard ? 6.0 : 2.0, rng);
  return to_image(img);
}

ColorImage draw_can_label(int w, int h, const PrintStyle& s) {
  w = std::max(w, 16), h = std::max(h, 8);
  std::mt19937_64 rng(s.seed * 17 + 5);
  std::uniform_real_distribution<double> U(0, 1);
  cv::Mat img(h, w, CV_8UC3, sc(s.background));
  // Bands near top and bottom, a wavy brand band, logo on one side, text + table on the other.
  const int b = std::max(2, h / 10);
  cv::rectangle(img, cv::Rect(0, 0, w, b), sc(s.primary), cv::FILLED);
  cv::rectangle(img, cv::Rect(0, h - b, w, b), sc(s.primary), cv::FILLED);
  std::vector<cv::Point> wave;
  const double amp = h * 0.05, y0 = h * (0.55 + 0.15 * U(rng));
  for (int x = 0; x <= w; x += std::max(1, w / 64))
    wave.emplace_back(x, static_cast<int>(y0 + amp * std::sin(x * 4 * M_PI / w)));
  wave.emplace_back(w, h - b), wave.emplace_back(0, h - b);
  cv::fillPoly(img, std::vector<std::vector<cv::Point>>{wave}, sc(s.secondary), cv::LINE_AA);
  const int r = std::max(6, std::min(h / 4, w / 8));
  draw_logo(img, cv::Point(w / 4, h / 3 + r / 3), r, s, rng);
  draw_text_block(img, cv::Rect(w / 2 + 4, b + 4, w / 3, h / 3), std::max(5, h / 22), s.ink, rng);
  // Nutrition-like table: a ruled box with rows.
  cv::Rect table(w * 3 / 4, h / 2, w / 5, h / 3);
  cv::rectangle(img, table, cv::Scalar(250, 250, 250), cv::FILLED);
  for (int y = table.y; y < table.y + table.height; y += std::max(3, table.height / 7))
    cv::line(img, {table.x, y}, {table.x + table.width, y}, sc(s.ink), 1);
  cv::rectangle(img, table, sc(s.ink), 1);
  draw_barcode(img, cv::Rect(w * 9 / 10 - w / 24, h / 6, w / 12, h / 4), rng);
  add_grain(img, 0.03, 2.0, rng);
  return to_image(img);
}

ColorImage draw_can_lid(int size, std::uint64_t seed) {
  size = std::max(size, 8);
  std::mt19937_64 rng(seed);
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(175, 178, 182));
  const cv::Point c(size / 2, size / 2);
  for (int k = 0; k < 3; ++k)
    cv::circle(img, c, size / 2 - 1 - k * size / 14,
               cv::Scalar(120 + 30 * k, 122 + 30 * k, 128 + 30 * k), std::max(1, size / 40),
               cv::LINE_AA);
  cv::circle(img, c + cv::Point(size / 8, 0), size / 14, cv::Scalar(140, 142, 146),
             std::max(1, size / 60), cv::LINE_AA);
  add_grain(img, 0.05, 4.0, rng);
  return to_image(img);
}

ColorImage draw_wood(int w, int h, std::uint64_t seed, Rgb8 base) {
  std::mt19937_64 rng(seed);
  const cv::Mat warp = value_noise(w, h, std::max(16, h / 3), 3, rng);
  const cv::Mat fine = value_noise(w, h, 4.0, 2, rng);
  std::uniform_real_distribution<double> U(0, 1);
  const double freq = 2 * M_PI / (6.0 + 6.0 * U(rng));
  cv::Mat img(h, w, CV_8UC3);
  for (int v = 0; v < h; ++v) {
    const float* wp = warp.ptr<float>(v);
    const float* fp = fine.ptr<float>(v);
    cv::Vec3b* row = img.ptr<cv::Vec3b>(v);
    for (int u = 0; u < w; ++u) {
      // Grain runs along u (the board's length): stripes in v, warped.
      const double g = 0.5 + 0.5 * std::sin(freq * (v + 18.0 * wp[u]));
      const double k = 0.78 + 0.16 * g + 0.08 * fp[u];
      row[u] = cv::Vec3b(cv::saturate_cast<uchar>(base.r * k), cv::saturate_cast<uchar>(base.g * k),
                         cv::saturate_cast<uchar>(base.b * k * 0.97));
    }
  }
  // A few knots.
  for (int i = 0; i < std::max(1, w * h / 150000); ++i) {
    const cv::Point c(static_cast<int>(U(rng) * w), static_cast<int>(U(rng) * h));
    cv::ellipse(
        img, c, cv::Size(6 + static_cast<int>(U(rng) * 8), 3 + static_cast<int>(U(rng) * 4)), 0, 0,
        360, cv::Scalar(base.r * 0.55, base.g * 0.5, base.b * 0.45), cv::FILLED, cv::LINE_AA);
  }
  return to_image(img);
}

ColorImage draw_concrete(int size, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const cv::Mat n1 = value_noise(size, size, size / 4.0, 5, rng);
  const cv::Mat n2 = value_noise(size, size, 3.0, 1, rng);
  cv::Mat img(size, size, CV_8UC3);
  for (int v = 0; v < size; ++v)
    for (int u = 0; u < size; ++u) {
      const double g = 150 + 22 * n1.at<float>(v, u) + 10 * n2.at<float>(v, u);
      img.at<cv::Vec3b>(v, u) =
          cv::Vec3b(cv::saturate_cast<uchar>(g), cv::saturate_cast<uchar>(g * 0.98),
                    cv::saturate_cast<uchar>(g * 0.95));
    }
  // A painted safety line along one edge of the tile.
  cv::rectangle(img, cv::Rect(0, size * 7 / 8, size, size / 24), cv::Scalar(230, 190, 30),
                cv::FILLED);
  return to_image(img);
}

ColorImage draw_painted_wall(int size, std::uint64_t seed, Rgb8 base) {
  std::mt19937_64 rng(seed);
  const cv::Mat n1 = value_noise(size, size, size / 3.0, 3, rng);
  cv::Mat img(size, size, CV_8UC3);
  for (int v = 0; v < size; ++v)
    for (int u = 0; u < size; ++u) {
      const double k = 1.0 + 0.05 * n1.at<float>(v, u);
      img.at<cv::Vec3b>(v, u) =
          cv::Vec3b(cv::saturate_cast<uchar>(base.r * k), cv::saturate_cast<uchar>(base.g * k),
                    cv::saturate_cast<uchar>(base.b * k));
    }
  return to_image(img);
}

}  // namespace orpe::synth
