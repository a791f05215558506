#pragma once
// Point tables for the LAZ tests: LAS point formats 0-3 with values that exercise every
// branch of the LAZ codecs (returns of a pulse sharing a GPS time, interleaved flight lines,
// grey and coloured points, jumps in X, Y and Z), from a generator that gives the same
// values on every platform (a 64-bit linear congruential generator, no <random>
// distributions), so a file written once can be checked against the table in a test.
#include <cstdint>
#include <string>
#include <vector>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io::testing {

class Lcg {
 public:
  explicit Lcg(std::uint64_t seed) : state_(seed) {}
  std::uint32_t next() {
    state_ = state_ * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<std::uint32_t>(state_ >> 33);
  }
  /// An integer in [0, n).
  std::uint32_t below(std::uint32_t n) { return next() % n; }

 private:
  std::uint64_t state_;
};

/// `count` points of LAS 1.2 point format `format` (0-3) with every standard field, on the
/// grid of scale 0.01 and offset (1000, 2000, 0); `extra` adds a float32 attribute
/// "amplitude" and a uint16 "echo_width" (extra bytes).
inline PointTable laz_test_table(int format, std::size_t count, std::uint64_t seed, bool extra) {
  Lcg random(seed);
  PointTable t;
  t.quantization = PositionQuantization{Vec3(0.01, 0.01, 0.01), Vec3(1000, 2000, 0)};
  t.las = LasMetadata{};
  t.las->version_minor = 2;
  t.las->point_format = format;
  std::vector<std::vector<double>> v(21, std::vector<double>(count));
  std::int64_t x = 5000, y = 7000, z = 300;
  double time = 350000.25;
  double other_line = 360000.5;
  int returns = 1, this_return = 1;
  std::uint32_t red = 20000, green = 20000, blue = 20000;
  for (std::size_t i = 0; i < count; ++i) {
    // A pulse of 1-5 returns shares its GPS time; the next pulse follows 10 microseconds later.
    if (this_return == returns) {
      returns = 1 + static_cast<int>(random.below(5));
      this_return = 1;
      time += 1e-5 * (1 + (random.below(20) == 0 ? 7 : 0));
      if (random.below(30) == 0) std::swap(time, other_line);  // another flight line
    } else {
      ++this_return;
    }
    x += static_cast<std::int64_t>(random.below(41)) - 20 + (random.below(50) == 0 ? 100000 : 0);
    y += static_cast<std::int64_t>(random.below(31)) - 10;
    z = random.below(10) == 0 ? z + static_cast<std::int64_t>(random.below(20001)) - 10000 : z + static_cast<std::int64_t>(random.below(7)) - 3;
    t.positions.push_back(Vec3(1000 + 0.01 * static_cast<double>(x), 2000 + 0.01 * static_cast<double>(y), 0.01 * static_cast<double>(z)));
    v[0][i] = random.below(4) == 0 ? v[0][i > 0 ? i - 1 : 0] : random.below(65536);  // intensity
    v[1][i] = this_return;
    v[2][i] = returns;
    v[3][i] = random.below(2);                                    // scan direction
    v[4][i] = random.below(10) == 0 ? 1 : 0;                      // edge of flight line
    v[5][i] = random.below(3) == 0 ? 2 : random.below(32);        // classification
    v[6][i] = random.below(20) == 0 ? 1 : 0;                      // synthetic
    v[7][i] = random.below(20) == 0 ? 1 : 0;                      // key point
    v[8][i] = random.below(20) == 0 ? 1 : 0;                      // withheld
    v[9][i] = static_cast<double>(random.below(181)) - 90;        // scan angle rank
    v[10][i] = random.below(5) == 0 ? random.below(256) : 7;      // user data
    v[11][i] = random.below(50) == 0 ? random.below(65536) : 12;  // point source id
    v[12][i] = time;
    if (random.below(8) == 0) red = random.below(65536);
    if (random.below(8) == 0) green = random.below(65536);
    if (random.below(8) == 0) blue = random.below(65536);
    const bool grey = random.below(3) == 0;
    v[13][i] = red;
    v[14][i] = grey ? red : green;
    v[15][i] = grey ? red : blue;
    v[16][i] = static_cast<float>(random.below(100000)) * 0.25f;  // amplitude
    v[17][i] = random.below(3000);                                  // echo width
  }
  t.set("intensity", ScalarType::UInt16, v[0]);
  t.set("return_number", ScalarType::UInt8, v[1]);
  t.set("number_of_returns", ScalarType::UInt8, v[2]);
  t.set("scan_direction_flag", ScalarType::UInt8, v[3]);
  t.set("edge_of_flight_line", ScalarType::UInt8, v[4]);
  t.set("classification", ScalarType::UInt8, v[5]);
  t.set("synthetic", ScalarType::UInt8, v[6]);
  t.set("key_point", ScalarType::UInt8, v[7]);
  t.set("withheld", ScalarType::UInt8, v[8]);
  t.set("scan_angle_rank", ScalarType::Int8, v[9]);
  t.set("user_data", ScalarType::UInt8, v[10]);
  t.set("point_source_id", ScalarType::UInt16, v[11]);
  if (format == 1 || format == 3) t.set("gps_time", ScalarType::Float64, v[12]);
  if (format == 2 || format == 3) {
    t.set("red", ScalarType::UInt16, v[13]);
    t.set("green", ScalarType::UInt16, v[14]);
    t.set("blue", ScalarType::UInt16, v[15]);
  }
  if (extra) {
    t.set("amplitude", ScalarType::Float32, v[16]);
    t.set("echo_width", ScalarType::UInt16, v[17]);
  }
  return t;
}

/// `count` points of LAS 1.4 point format `format` (6-8): the values of laz_test_table, and
/// what 1.4 adds: up to 15 returns, 256 classes, the overlap flag, four scanner channels
/// (interleaved in runs, each with its own flight line of GPS times), scan angles in 0.006
/// degrees, and NIR for format 8.
inline PointTable laz14_test_table(int format, std::size_t count, std::uint64_t seed, bool extra) {
  PointTable t = laz_test_table(format == 6 ? 1 : 3, count, seed, extra);
  t.las->version_minor = 4;
  t.las->point_format = format;
  t.las->global_encoding = 16;
  Lcg random(seed * 7 + 1);
  std::vector<double> channel(count), overlap(count), angle(count), nir(count), classification(count);
  std::vector<double>& returns = t.find("number_of_returns")->values;
  std::vector<double>& number = t.find("return_number")->values;
  std::vector<double>& gps = t.find("gps_time")->values;
  unsigned current = 0;
  double nir_value = 1000;
  for (std::size_t i = 0; i < count; ++i) {
    // A pulse (same GPS time) stays on its channel; a new pulse may switch channel.
    if (number[i] == 1 && random.below(6) == 0) current = random.below(4);
    channel[i] = current;
    gps[i] += 1000.0 * current;
    if (random.below(40) == 0) {
      // Many returns (up to 15).
      returns[i] = 8 + random.below(8);
      number[i] = 1 + random.below(static_cast<std::uint32_t>(returns[i]));
    }
    overlap[i] = random.below(15) == 0 ? 1 : 0;
    angle[i] = random.below(3) == 0 ? static_cast<double>(random.below(30001)) - 15000 : (i > 0 ? angle[i - 1] : 0);
    if (random.below(6) == 0) nir_value = random.below(65536);
    nir[i] = nir_value;
    classification[i] = random.below(4) == 0 ? random.below(256) : 2;
  }
  t.attributes.erase(t.attributes.begin() + (t.find("scan_angle_rank") - t.attributes.data()));
  t.set("classification", ScalarType::UInt8, classification);
  t.set("overlap", ScalarType::UInt8, overlap);
  t.set("scanner_channel", ScalarType::UInt8, channel);
  t.set("scan_angle", ScalarType::Int16, angle);
  if (format == 8) t.set("nir", ScalarType::UInt16, nir);
  if (format == 6) {
    for (const char* name : {"red", "green", "blue"}) {
      if (Attribute* colour = t.find(name)) t.attributes.erase(t.attributes.begin() + (colour - t.attributes.data()));
    }
  }
  return t;
}

}  // namespace pointfair::io::testing
