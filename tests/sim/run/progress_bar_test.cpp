// Tests of sim/progress_bar: the drawn line (fraction, times, label) and the line-per-decile
// output when the stream is not a terminal.
#include "numen/sim/run/progress_bar.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

TEST(ProgressBar, RenderShowsFractionTimesAndLabel) {
  EXPECT_EQ(numen::sim::ProgressBar::render(0.5, 10.0, 10.0, "wall trapezoidal", 10),
            "[#####.....]  50% 10s elapsed, 10s left  wall trapezoidal");
  EXPECT_EQ(numen::sim::ProgressBar::render(1.0, 75.0, 0.0, "done", 4),
            "[####] 100% 1m15s elapsed, 0s left  done");
  EXPECT_EQ(numen::sim::ProgressBar::render(0.0, 0.0, -1.0, "", 3),
            "[...]   0% 0s elapsed, ? left  ");
  EXPECT_EQ(numen::sim::ProgressBar::render(2.0, 1.0, 0.0, "", 2).substr(0, 4), "[##]");  // clamped
}

TEST(ProgressBar, WritesOneLinePerDecileToANonTerminal) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    numen::sim::ProgressBar bar(f, 10);
    for (int i = 1; i <= 100; ++i) bar.update(i, 100.0, "x");
    bar.finish();
  }
  std::rewind(f);
  int lines = 0;
  for (int c; (c = std::fgetc(f)) != EOF;) lines += c == '\n';
  std::fclose(f);
  EXPECT_EQ(lines, 11 + 1);  // deciles 0 … 10, then finish()
}
