// Reading and writing LAZ against plain LAS (Google Benchmark): points per second of
// read_las and write_las on an airborne-like strip of a million points (scan lines across a
// gently rolling ground, GPS time along the lines, intensity and returns as a scanner gives
// them, colours for formats 3 and 7), in LAS 1.2 point formats 1 and 3 and LAS 1.4 formats 6
// and 7. The files go to the system's temporary folder and are removed at the end.
//
//   pointfair_bench_formats --benchmark_filter=Laz --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pointfair/io/las.hpp"
#include "pointfair/io/point_table.hpp"

namespace {

using namespace pointfair;
using namespace pointfair::io;
namespace fs = std::filesystem;

constexpr std::size_t kPoints = 1'000'000;

// A strip of scan lines of 500 points each, 0.25 units apart along the line and 0.3 across,
// over ground z = 2 sin(x / 40) + cos(y / 25) with a point in ten on a canopy 8 to 15 above it
// (its first of two returns; the ground under it the second).
PointTable scan_strip(int format) {
  const bool las14 = format >= 6, colour = format == 3 || format == 7;
  PointTable t;
  t.quantization = PositionQuantization{Vec3(0.01, 0.01, 0.01), Vec3(500000, 4000000, 0)};
  t.las = LasMetadata{};
  t.las->version_minor = las14 ? 4 : 2;
  t.las->point_format = format;
  std::vector<double> intensity(kPoints), return_number(kPoints), returns(kPoints), classification(kPoints);
  std::vector<double> gps_time(kPoints), angle(kPoints), source(kPoints, 17), red(kPoints), green(kPoints), blue(kPoints);
  std::uint64_t state = 12345;
  const auto noise = [&state] {  // in [0, 1)
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  };
  t.positions.reserve(kPoints);
  for (std::size_t i = 0; i < kPoints; ++i) {
    const std::size_t line = i / 500, along = i % 500;
    const double x = 500000 + 0.25 * static_cast<double>(along) + 0.05 * noise();
    const double y = 4000000 + 0.3 * static_cast<double>(line);
    const double ground = 2 * std::sin((x - 500000) / 40) + std::cos((y - 4000000) / 25);
    const bool canopy = i % 10 == 0, under = i % 10 == 1;
    const double z = ground + (canopy ? 8 + 7 * noise() : 0.02 * noise());
    t.positions.push_back(Vec3(std::round(x * 100) / 100, std::round(y * 100) / 100, std::round(z * 100) / 100));
    returns[i] = canopy || under ? 2 : 1;
    return_number[i] = under ? 2 : 1;
    classification[i] = canopy ? 5 : 2;
    intensity[i] = std::floor((canopy ? 300 : 900) + 200 * noise());
    gps_time[i] = 250000.0 + 1e-5 * static_cast<double>(i - (under ? 1 : 0));
    angle[i] = std::round(-20 + 40 * static_cast<double>(along) / 500);
    red[i] = canopy ? 9000 : 30000 + std::floor(2000 * noise());
    green[i] = canopy ? 30000 : 26000 + std::floor(2000 * noise());
    blue[i] = canopy ? 8000 : 20000 + std::floor(2000 * noise());
  }
  t.set("intensity", ScalarType::UInt16, intensity);
  t.set("return_number", ScalarType::UInt8, return_number);
  t.set("number_of_returns", ScalarType::UInt8, returns);
  t.set("classification", ScalarType::UInt8, classification);
  t.set("point_source_id", ScalarType::UInt16, source);
  t.set("gps_time", ScalarType::Float64, gps_time);
  if (las14) {
    for (double& a : angle) a /= 0.006;  // units of 0.006 degrees
    t.set("scan_angle", ScalarType::Int16, angle);
  } else {
    t.set("scan_angle_rank", ScalarType::Int8, angle);
  }
  if (colour) {
    t.set("red", ScalarType::UInt16, red);
    t.set("green", ScalarType::UInt16, green);
    t.set("blue", ScalarType::UInt16, blue);
  }
  return t;
}

fs::path bench_file(int format, bool laz) {
  return fs::temp_directory_path() / ("pointfair_bench_formats_" + std::to_string(format) + (laz ? ".laz" : ".las"));
}

void set_rate(benchmark::State& state, const fs::path& file) {
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * kPoints));
  state.counters["MB"] = static_cast<double>(fs::file_size(file)) / 1e6;
}

void BM_Write(benchmark::State& state, bool laz) {
  const int format = static_cast<int>(state.range(0));
  const PointTable table = scan_strip(format);
  const fs::path file = bench_file(format, laz);
  for (auto _ : state) write_las(file, table);
  set_rate(state, file);
}

void BM_Read(benchmark::State& state, bool laz) {
  const int format = static_cast<int>(state.range(0));
  const fs::path file = bench_file(format, laz);
  write_las(file, scan_strip(format));
  for (auto _ : state) benchmark::DoNotOptimize(read_las(file).positions.data());
  set_rate(state, file);
  fs::remove(file);
}

void BM_WriteLas(benchmark::State& state) { BM_Write(state, false); }
void BM_WriteLaz(benchmark::State& state) { BM_Write(state, true); }
void BM_ReadLas(benchmark::State& state) { BM_Read(state, false); }
void BM_ReadLaz(benchmark::State& state) { BM_Read(state, true); }

}  // namespace

BENCHMARK(BM_WriteLas)->Arg(1)->Arg(3)->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_WriteLaz)->Arg(1)->Arg(3)->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ReadLas)->Arg(1)->Arg(3)->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ReadLaz)->Arg(1)->Arg(3)->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
