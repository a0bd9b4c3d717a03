// LoomingFit against closed forms: a ball of diameter D closing head-on at speed v looks
// θ(t) = f D / L(t) wide with L(t) = L0 − v t, so τ(t) = θ/θ̇ = L(t) / v exactly.
#include "fdv/tracking/looming.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fdv/core/error.h"

namespace fdv {
namespace {

constexpr double kF = 300, kD = 0.1;  // focal length [px], ball diameter [m]
constexpr TimeNs kLoomingWindow = 25 * kNsPerMs;

double size_at(double L0, double v, TimeNs t) { return kF * kD / (L0 - v * to_seconds(t)); }

TEST(Looming, HeadOnBallGivesTheTimeToContactExactly) {
  LoomingFit fit;
  const double L0 = 3, v = 10;  // 10 px at 3 m, 24 px at 1.25 m
  for (int k = 0; k < 8; ++k) ASSERT_TRUE(fit.add(k * kLoomingWindow, size_at(L0, v, k * kLoomingWindow), 1e3));
  EXPECT_EQ(fit.detections(), LoomingOptions{}.fit_detections);
  const TimeNs t = 7 * kLoomingWindow;
  const auto l = fit.at(t);
  ASSERT_TRUE(l);
  EXPECT_NEAR(l->size_px, size_at(L0, v, t), 1e-9);
  ASSERT_TRUE(l->tau_s);
  EXPECT_NEAR(*l->tau_s, (L0 - v * to_seconds(t)) / v, 1e-9);  // 0.125 s
  // Evaluated ahead of the newest size too (the fit is a line in 1/θ).
  EXPECT_NEAR(*fit.at(t + kLoomingWindow)->tau_s, (L0 - v * to_seconds(t + kLoomingWindow)) / v, 1e-9);
}

TEST(Looming, ARecedingBallHasANegativeTimeToContact) {
  LoomingFit fit;
  for (int k = 0; k < 8; ++k) fit.add(k * kLoomingWindow, size_at(0.5, -6, k * kLoomingWindow), size_at(0.5, -6, k * kLoomingWindow));
  const auto l = fit.at(7 * kLoomingWindow);  // 60 px at 0.5 m shrinking to 19 px at 1.55 m
  ASSERT_TRUE(l && l->tau_s);
  EXPECT_NEAR(*l->tau_s, -(0.5 + 6 * to_seconds(7 * kLoomingWindow)) / 6, 1e-9);
}

// A hand-held ball: its size stays 12 px give or take the detector's noise; no τ is claimed.
TEST(Looming, ABallThatStopsGrowingHasNoTimeToContact) {
  std::mt19937 rng(3);
  const LoomingOptions o;
  std::normal_distribution<double> noise(0, o.size_sigma_px + o.size_sigma_fraction * 12);
  int claimed = 0;
  for (int trial = 0; trial < 200; ++trial) {
    LoomingFit fit;
    for (int k = 0; k < 8; ++k) fit.add(k * kLoomingWindow, 12 + noise(rng), 50);
    const auto l = fit.at(7 * kLoomingWindow);
    ASSERT_TRUE(l);
    EXPECT_NEAR(l->size_px, 12, 3 * l->size_sigma_px);
    claimed += l->tau_s.has_value();
  }
  // |ẏ| > 2σ by chance in about 4.6 % of fits.
  EXPECT_LT(claimed, 20);
}

// The σ's are calibrated where the first-order propagation holds (noise small against the size):
// with sizes drawn with the modelled noise, the true θ and τ lie within 1σ of the fit in about
// 68 % of trials and within 2σ in about 95 % (a ball closing from 3 m at 12 m/s, 10-33 px, fitted
// over 8 windows, at the 8th).
TEST(Looming, SigmasAreCalibrated) {
  LoomingOptions o;
  o.size_sigma_px = 0.3;
  o.size_sigma_fraction = 0.03;
  std::mt19937 rng(7);
  std::normal_distribution<double> unit(0, 1);
  const double L0 = 3, v = 12;
  const TimeNs t = 7 * kLoomingWindow;
  const double true_tau = (L0 - v * to_seconds(t)) / v, true_size = size_at(L0, v, t);
  int trials = 0, tau1 = 0, tau2 = 0, size1 = 0, size2 = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    LoomingFit fit(o);
    for (int k = 0; k < 8; ++k) {
      const double s = size_at(L0, v, k * kLoomingWindow);
      fit.add(k * kLoomingWindow, s + (o.size_sigma_px + o.size_sigma_fraction * s) * unit(rng), 1e3);
    }
    const auto l = fit.at(t);
    if (!l || !l->tau_s) continue;
    ++trials;
    const double et = std::abs(*l->tau_s - true_tau) / *l->tau_sigma_s;
    const double es = std::abs(l->size_px - true_size) / l->size_sigma_px;
    tau1 += et <= 1;
    tau2 += et <= 2;
    size1 += es <= 1;
    size2 += es <= 2;
  }
  ASSERT_GT(trials, 1900);  // the growth shows in almost every trial
  EXPECT_NEAR(static_cast<double>(tau1) / trials, 0.68, 0.06);
  EXPECT_NEAR(static_cast<double>(tau2) / trials, 0.95, 0.04);
  EXPECT_NEAR(static_cast<double>(size1) / trials, 0.68, 0.06);
  EXPECT_NEAR(static_cast<double>(size2) / trials, 0.95, 0.04);
}

TEST(Looming, BadSizesAreIgnoredAndOptionsChecked) {
  LoomingFit fit;
  EXPECT_FALSE(fit.add(0, std::nan(""), 5));
  EXPECT_FALSE(fit.add(0, 0, 5));
  EXPECT_FALSE(fit.add(0, -3, 5));
  EXPECT_FALSE(fit.add(0, INFINITY, INFINITY));
  EXPECT_TRUE(fit.add(kLoomingWindow, 5, 5));
  EXPECT_FALSE(fit.add(0, 5, 5));  // older than the newest
  EXPECT_EQ(fit.detections(), 1);
  EXPECT_FALSE(fit.at(kLoomingWindow));  // too few for a fit
  LoomingOptions bad;
  bad.min_detections = 1;
  EXPECT_THROW(LoomingFit{bad}, ConfigError);
  bad = {};
  bad.size_sigma_px = bad.size_sigma_fraction = 0;
  EXPECT_THROW(LoomingFit{bad}, ConfigError);
}

}  // namespace
}  // namespace fdv
