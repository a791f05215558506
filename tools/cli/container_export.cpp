#include "container_export.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "run_support.hpp"
#include "pointfair/common/colour.hpp"
#include "pointfair/io/attribute_roles.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/container_reader.hpp"

namespace pointfair::cli {

namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kBlockRows = 1u << 16;

// Calls `f` with blocks of the colour scalar of every point (max |k1|, |k2| or the
// Laplacian norm, as add_result_columns), in row order.
void for_each_scalar_block(const fs::path& container, ColourBy by,
                           const std::function<void(const std::vector<double>&)>& f) {
  const auto file = tiles::h5::File::open(container, false);
  const std::string a = std::string(tiles::layout::run_attributes) + "/";
  const std::uint64_t n = tiles::point_count(file);
  std::vector<double> values, second;
  for (std::uint64_t first = 0; first < n; first += kBlockRows) {
    const std::uint64_t count = std::min(kBlockRows, n - first);
    values.resize(count);
    if (by == ColourBy::Laplacian) {
      file.dataset(a + "laplacian_norm").read_rows(first, count, values.data());
    } else {
      second.resize(count);
      file.dataset(a + "k1").read_rows(first, count, values.data());
      file.dataset(a + "k2").read_rows(first, count, second.data());
      for (std::uint64_t i = 0; i < count; ++i) values[i] = std::max(std::abs(values[i]), std::abs(second[i]));
    }
    f(values);
  }
}

// An order-preserving key of a finite double.
std::uint64_t key_of(double v) {
  const auto bits = std::bit_cast<std::uint64_t>(v);
  return (bits >> 63) != 0 ? ~bits : bits | (std::uint64_t{1} << 63);
}
double value_of(std::uint64_t key) {
  const std::uint64_t bits = (key >> 63) != 0 ? key & ~(std::uint64_t{1} << 63) : ~key;
  return std::bit_cast<double>(bits);
}

// colour_by_scalar's low and high (the clip and 1 - clip quantiles of the finite values, at
// the same ranks) in bounded memory: a radix selection, 16 bits per pass.
std::array<double, 2> colour_range(const fs::path& container, ColourBy by, double clip) {
  std::uint64_t finite = 0;
  for_each_scalar_block(container, by, [&](const std::vector<double>& block) {
    for (const double v : block) finite += std::isfinite(v) ? 1 : 0;
  });
  if (finite == 0) return {0.0, 0.0};
  clip = std::clamp(clip, 0.0, 0.5);
  const auto last = static_cast<double>(finite - 1);
  std::array<std::uint64_t, 2> rank{static_cast<std::uint64_t>(std::lround(clip * last)),
                                    static_cast<std::uint64_t>(std::lround((1.0 - clip) * last))};
  std::array<std::uint64_t, 2> prefix{0, 0};
  std::vector<std::uint64_t> histogram(2 * 65536);
  for (int shift = 48; shift >= 0; shift -= 16) {
    std::fill(histogram.begin(), histogram.end(), 0);
    const std::uint64_t high_mask = shift == 48 ? 0 : ~std::uint64_t{0} << (shift + 16);
    for_each_scalar_block(container, by, [&](const std::vector<double>& block) {
      for (const double v : block) {
        if (!std::isfinite(v)) continue;
        const std::uint64_t k = key_of(v);
        for (std::size_t q = 0; q < 2; ++q)
          if ((k & high_mask) == prefix[q]) ++histogram[q * 65536 + ((k >> shift) & 0xFFFF)];
      }
    });
    for (std::size_t q = 0; q < 2; ++q) {
      std::uint64_t digit = 0;
      while (rank[q] >= histogram[q * 65536 + digit]) rank[q] -= histogram[q * 65536 + digit++];
      prefix[q] |= digit << shift;
    }
  }
  return {value_of(prefix[0]), value_of(prefix[1])};
}

}  // namespace

bool container_has_normal_columns(const fs::path& container) {
  return !io::normal_columns(tiles::ContainerChunkReader(container, {.original_order = false}).schema()).empty();
}

ExportSummary export_container(const fs::path& container, const fs::path& output, const OutputOptions& out,
                               const tiles::StreamExportOptions& options, const fs::path& input) {
  ExportSummary summary;
  {
    const auto f = tiles::h5::File::open(container, false);
    summary.has_results = !options.input_positions && tiles::has_finished_run(f) &&
                          f.exists(std::string(tiles::layout::run_attributes) + "/k1");
  }
  const bool colour = summary.has_results && out.colour_by != ColourBy::None;
  // Normals of the input no longer match smoothed positions: the run's replace them.
  const bool stale_normals = summary.has_results && container_has_normal_columns(container);
  const bool results = summary.has_results && (out.attributes || colour || stale_normals);
  // The curvature columns' type, for every chunk alike: double when any value would not fit
  // float (a cloud at an extreme scale), as in core (curvature_type).
  io::ScalarType curvatures = io::ScalarType::Float32;
  if (results && out.attributes) {
    const auto f = tiles::h5::File::open(container, false);
    const std::string a = std::string(tiles::layout::run_attributes) + "/";
    std::vector<double> values;
    for (const char* name : {"k1", "k2", "mean_curvature", "laplacian_norm"}) {
      const tiles::h5::Dataset d = f.dataset(a + name);
      for (std::uint64_t first = 0; first < d.rows() && curvatures == io::ScalarType::Float32; first += 1u << 16) {
        const std::uint64_t count = std::min<std::uint64_t>(1u << 16, d.rows() - first);
        values.resize(count);
        d.read_rows(first, count, values.data());
        for (const double v : values)
          if (!fits_float(v)) curvatures = io::ScalarType::Float64;
      }
    }
  }
  std::array<double, 2> range{0.0, 0.0};
  if (colour) range = colour_range(container, out.colour_by, out.colour_clip);

  // The result columns, without colours: those are added here with the global range.
  OutputOptions columns = out;
  columns.colour_by = ColourBy::None;
  columns.attribute_prefix = attribute_prefix_for(output);
  tiles::StreamExportOptions stream = options;
  stream.run_attributes = results;
  stream.write = write_options(out, input);
  stream.columns = [&](io::PointTable& table, const PointAttributes& a) {
    if (!results) return;
    add_result_columns(table, a, columns, out.attributes, curvatures);
    if (!colour) return;
    std::vector<double> red(table.size()), green(table.size()), blue(table.size());
    for (std::size_t i = 0; i < table.size(); ++i) {
      const double v = out.colour_by == ColourBy::Laplacian ? a.laplacian_norm[i]
                                                             : std::max(std::abs(a.k1[i]), std::abs(a.k2[i]));
      const Rgb c = hue_colour(v, range[0], range[1]);
      red[i] = c[0];
      green[i] = c[1];
      blue[i] = c[2];
    }
    table.set("red", io::ScalarType::UInt8, std::move(red));
    table.set("green", io::ScalarType::UInt8, std::move(green));
    table.set("blue", io::ScalarType::UInt8, std::move(blue));
  };
  summary.points = tiles::export_points(container, output, stream);
  return summary;
}

}  // namespace pointfair::cli
