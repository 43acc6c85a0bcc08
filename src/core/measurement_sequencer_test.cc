#include "ekf_vislam/core/measurement_sequencer.h"

#include <gtest/gtest.h>

namespace ekf_vislam {
namespace {

TwistData twist(double t) {
  TwistData m;
  m.stamp = t;
  return m;
}
AccelerometerData accel(double t) {
  AccelerometerData m;
  m.stamp = t;
  return m;
}
FeatureFrame frame(double t) {
  FeatureFrame m;
  m.stamp = t;
  return m;
}
std::string describe(const std::vector<Measurement>& ms) {
  std::string s;
  for (const Measurement& m : ms) {
    s += (std::holds_alternative<TwistData>(m)           ? "T"
          : std::holds_alternative<AccelerometerData>(m) ? "A"
                                                         : "F") +
         std::to_string(static_cast<int>(stampOf(m) * 10)) + " ";
  }
  return s;
}

TEST(MeasurementSequencer, ReleasesInStampOrderTwistFirstAtEqualStamps) {
  MeasurementSequencer seq;
  seq.push(frame(0.0));  // the frame arrives before its twist
  EXPECT_TRUE(seq.popReady().empty());
  seq.push(twist(0.0));
  EXPECT_EQ(describe(seq.popReady()), "T0 F0 ");
  seq.push(twist(0.1));
  seq.push(twist(0.2));  // twists run ahead: held until frames reach them
  EXPECT_TRUE(seq.popReady().empty());
  seq.push(frame(0.1));
  EXPECT_EQ(describe(seq.popReady()), "T1 F1 ");
  seq.push(frame(0.2));
  EXPECT_EQ(describe(seq.popReady()), "T2 F2 ");
  EXPECT_EQ(seq.late(), 0u);
}

TEST(MeasurementSequencer, AnAccelerometerStreamIsWaitedForOnceItHasDeliveredASample) {
  MeasurementSequencer seq;
  seq.push(twist(0.0));
  seq.push(frame(0.0));
  EXPECT_EQ(describe(seq.popReady()), "T0 F0 ");  // no accelerometer yet: nothing to wait for
  seq.push(accel(0.1));
  seq.push(frame(0.2));
  seq.push(twist(0.2));
  // Accelerometer first at equal stamps, then twist, then frame; the stream has reached 0.1
  // only, so 0.2 waits for it.
  EXPECT_EQ(describe(seq.popReady()), "A1 ");
  seq.push(accel(0.2));
  EXPECT_EQ(describe(seq.popReady()), "A2 T2 F2 ");
  EXPECT_EQ(seq.late(), 0u);
}

TEST(MeasurementSequencer, OutOfOrderArrivalsAreSorted) {
  MeasurementSequencer seq;
  seq.push(twist(0.2));
  seq.push(twist(0.1));
  seq.push(frame(0.2));
  seq.push(frame(0.1));
  EXPECT_EQ(describe(seq.popReady()), "T1 F1 T2 F2 ");
}

TEST(MeasurementSequencer, OneStreamStoppingReleasesAfterMaxDelay) {
  MeasurementSequencer::Options options;
  options.max_delay = 0.25;
  MeasurementSequencer seq(options);
  seq.push(twist(0.0));
  seq.push(frame(0.0));
  EXPECT_EQ(describe(seq.popReady()), "T0 F0 ");
  for (int k = 1; k <= 5; ++k) seq.push(twist(0.1 * k));  // no more frames
  EXPECT_EQ(describe(seq.popReady()), "T1 T2 ");          // older than newest - 0.25
  EXPECT_EQ(describe(seq.flush()), "T3 T4 T5 ");
}

// A bag played at 10x: frames every 0.01 s of wall time, the twist stream 0.1 s of wall time (1 s
// of message time) behind them. Nothing is released out of order; once the twists stop, the frames
// go after max_delay in both clocks.
TEST(MeasurementSequencer, ALateStreamIsWaitedForInWallTimeToo) {
  MeasurementSequencer::Options options;
  options.max_delay = 0.25;
  MeasurementSequencer seq(options);
  seq.push(twist(0.0), 0.0);
  for (int k = 0; k <= 10; ++k) seq.push(frame(0.1 * k), 0.01 * k);
  // Message time alone would release the frames up to 0.7 here; the twists are only late.
  EXPECT_EQ(describe(seq.popReady(0.10)), "T0 F0 ");
  for (int k = 1; k <= 10; ++k) seq.push(twist(0.1 * k), 0.20);
  EXPECT_EQ(describe(seq.popReady(0.20)),
            "T1 F1 T2 F2 T3 F3 T4 F4 T5 F5 T6 F6 T7 F7 T8 F8 T9 F9 T10 F10 ");
  EXPECT_EQ(seq.late(), 0u);
  // The twist stream stops.
  for (int k = 11; k <= 15; ++k) seq.push(frame(0.1 * k), 0.21 + 0.01 * (k - 11));
  EXPECT_TRUE(seq.popReady(0.30).empty());              // 0.09 s or less of wall time
  EXPECT_EQ(describe(seq.popReady(0.50)), "F11 F12 ");  // 1.5 - 1.3 is within 0.25
}

TEST(MeasurementSequencer, LateMessagesAreCountedAndStillReturned) {
  MeasurementSequencer seq;
  seq.push(twist(0.1));
  seq.push(frame(0.1));
  EXPECT_EQ(seq.popReady().size(), 2u);
  seq.push(frame(0.05));  // older than what was released
  EXPECT_EQ(seq.late(), 1u);
  EXPECT_EQ(describe(seq.flush()), "F0 ");
}

TEST(MeasurementSequencer, BufferIsBounded) {
  MeasurementSequencer::Options options;
  options.max_buffered = 10;
  options.max_delay = 1e9;
  MeasurementSequencer seq(options);
  for (int k = 0; k < 50; ++k) seq.push(twist(0.1 * k));
  seq.popReady();
  EXPECT_LE(seq.buffered(), 10u);
}

}  // namespace
}  // namespace ekf_vislam
