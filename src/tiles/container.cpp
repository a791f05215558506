#include "pointfair/tiles/container.hpp"

#include <algorithm>
#include <limits>
#include <cctype>
#include <cmath>

#include "pointfair/common/version.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/source_layout.hpp"
#include "temporary_file.hpp"

namespace pointfair::tiles {

namespace fs = std::filesystem;

namespace {

// Row blocks for permuted writes: bounded scratch memory whatever the cloud size.
constexpr std::uint64_t kBlockRows = 1u << 16;

// The bytes of a LAS source beyond its points and standard header fields, opaque: every
// VLR and EVLR (e.g. the coordinate reference system), the Extra Bytes descriptors, the
// project GUID and system identifier. See layout::las_records.
void write_bytes(h5::File& f, const std::string& path, std::string_view bytes) {
  h5::Dataset d = f.create_dataset(path, h5::Type::UInt8, bytes.size(), 0, {});
  if (!bytes.empty()) d.write_rows(0, bytes.size(), reinterpret_cast<const std::uint8_t*>(bytes.data()));
}

std::string read_bytes(const h5::File& f, const std::string& path) {
  const std::vector<std::uint8_t> v = f.dataset(path).read_all<std::uint8_t>();
  return std::string(v.begin(), v.end());
}

// A name field of a record: NUL-padded to `width` bytes.
std::string padded(const std::string& text, std::size_t width) {
  std::string out = text.substr(0, width);
  out.resize(width, '\0');
  return out;
}

std::string unpadded(std::string_view field) { return std::string(field.substr(0, field.find('\0'))); }

void write_las_records(h5::File& f, const io::LasMetadata& las) {
  const std::string g = layout::las_records;
  f.create_group(g);
  std::string payload, names;
  std::vector<std::uint64_t> table;
  for (const io::LasRecord& r : las.records) {
    table.insert(table.end(), {payload.size(), r.data.size(), r.record_id, r.extended ? 1u : 0u});
    payload += r.data;
    names += padded(r.user_id, 16) + padded(r.description, 32);
  }
  h5::Dataset t = f.create_dataset(g + "/table", h5::Type::UInt64, las.records.size(), 4, {});
  if (!table.empty()) t.write_rows(0, las.records.size(), table.data());
  h5::Dataset n = f.create_dataset(g + "/names", h5::Type::UInt8, las.records.size(), 48, {});
  if (!names.empty()) n.write_rows(0, las.records.size(), reinterpret_cast<const std::uint8_t*>(names.data()));
  write_bytes(f, g + "/payload", payload);
  write_bytes(f, g + "/extra_bytes_descriptors", las.extra_bytes_descriptors);
  write_bytes(f, g + "/project_guid", las.project_guid);
  f.set_attribute(g, "system_identifier", las.system_identifier);
}

void read_las_records(const h5::File& f, io::LasMetadata& las) {
  const std::string g = layout::las_records;
  if (!f.exists(g)) return;  // a container written before the records were kept
  const h5::Dataset t = f.dataset(g + "/table"), n = f.dataset(g + "/names");
  if (t.width() != 4 || n.width() != 48 || n.rows() != t.rows()) f.fail(g, "record table and names do not match");
  const std::vector<std::uint64_t> table = t.read_all<std::uint64_t>();
  const std::string names = read_bytes(f, g + "/names"), payload = read_bytes(f, g + "/payload");
  las.records.clear();
  for (std::size_t i = 0; i < t.rows(); ++i) {
    const std::uint64_t offset = table[4 * i], size = table[4 * i + 1];
    if (offset > payload.size() || size > payload.size() - offset || table[4 * i + 2] > 65535 ||
        (table[4 * i + 3] == 0 && size > 65535))
      f.fail(g, "record " + std::to_string(i) + " lies outside the payload or out of range");
    io::LasRecord r;
    r.user_id = unpadded(std::string_view(names).substr(48 * i, 16));
    r.description = unpadded(std::string_view(names).substr(48 * i + 16, 32));
    r.record_id = static_cast<std::uint16_t>(table[4 * i + 2]);
    r.extended = table[4 * i + 3] != 0;
    r.data = payload.substr(offset, size);
    las.records.push_back(std::move(r));
  }
  las.extra_bytes_descriptors = read_bytes(f, g + "/extra_bytes_descriptors");
  las.project_guid = read_bytes(f, g + "/project_guid");
  if (las.project_guid.size() != 16) f.fail(g, "project_guid must have 16 bytes");
  las.system_identifier = f.string_attribute(g, "system_identifier");
}

}  // namespace

// The LAS integer grid and format of a LAS input, so that export to LAS reproduces the
// input's integers: attributes of /points/positions (scale and offset) and /points.
void write_source_format(h5::File& f, const io::PointTable& table) {
  if (table.quantization) {
    const Vec3& scale = table.quantization->scale;
    const Vec3& offset = table.quantization->offset;
    f.set_attribute(layout::positions, "quantization_scale", std::span<const double>(scale.data(), 3));
    f.set_attribute(layout::positions, "quantization_offset", std::span<const double>(offset.data(), 3));
  }
  if (table.las) {
    f.set_attribute(layout::points, "las_version_minor", std::int64_t{table.las->version_minor});
    f.set_attribute(layout::points, "las_point_format", std::int64_t{table.las->point_format});
    f.set_attribute(layout::points, "las_global_encoding", std::int64_t{table.las->global_encoding});
    f.set_attribute(layout::points, "las_file_source_id", std::int64_t{table.las->file_source_id});
    write_las_records(f, *table.las);
  }
  const std::string source = io::encode_source_layout(table);
  if (!source.empty()) write_bytes(f, layout::source_layout, source);
}

void read_source_format(const h5::File& f, io::PointTable& table) {
  if (f.has_attribute(layout::positions, "quantization_scale")) {
    const std::vector<double> scale = f.doubles_attribute(layout::positions, "quantization_scale");
    const std::vector<double> offset = f.doubles_attribute(layout::positions, "quantization_offset");
    if (scale.size() != 3 || offset.size() != 3) f.fail(layout::positions, "quantization needs 3 scales and 3 offsets");
    io::PositionQuantization q;
    for (int a = 0; a < 3; ++a) {
      const auto k = static_cast<std::size_t>(a);
      if (!std::isfinite(scale[k]) || scale[k] == 0 || !std::isfinite(offset[k]))
        f.fail(layout::positions, "quantization scale must be finite and non-zero, offset finite");
      q.scale[a] = scale[k];
      q.offset[a] = offset[k];
    }
    table.quantization = q;
  }
  if (f.has_attribute(layout::points, "las_point_format")) {
    io::LasMetadata las;
    const auto in_range = [&](const char* name, std::int64_t high) {
      const std::int64_t v = f.int_attribute(layout::points, name);
      if (v < 0 || v > high) f.fail(layout::points, std::string(name) + " out of range");
      return v;
    };
    las.version_minor = static_cast<int>(in_range("las_version_minor", 4));
    las.point_format = static_cast<int>(in_range("las_point_format", 10));
    las.global_encoding = static_cast<std::uint16_t>(in_range("las_global_encoding", 65535));
    las.file_source_id = static_cast<std::uint16_t>(in_range("las_file_source_id", 65535));
    read_las_records(f, las);
    table.las = las;
  }
  if (f.exists(layout::source_layout) &&
      !io::decode_source_layout(read_bytes(f, layout::source_layout), table))
    f.fail(layout::source_layout, "not a layout this version wrote");
}

void write_container(const fs::path& file, const io::PointTable& table, const ImportOptions& options) {
  options.tiling.validate();
  io::require_output_path(file);
  const std::uint64_t n = table.size();
  for (const auto& a : table.attributes) {
    if (a.values.size() != n)
      throw io::IoError(file.string() + ": attribute " + a.name + " has " + std::to_string(a.values.size()) +
                        " values for " + std::to_string(n) + " points");
    if (a.name.empty() || a.name.find('/') != std::string::npos || a.name == ".")
      throw io::IoError(file.string() + ": attribute name '" + a.name + "' cannot name an HDF5 dataset");
  }
  const Tiling tiling = make_tiling(table.positions, options.tiling);
  const fs::path temp = temporary_name(file);
  RemoveOnExit remove_temp{temp};
  try {
    h5::File f = h5::File::create(temp);
    f.set_attribute("/", "pointfair_format", layout::format_name);
    f.set_attribute("/", "format_version", layout::format_version);
    f.set_attribute("/", "tool_version", version());
    f.set_attribute("/", "source_name", options.source_name);
    f.set_attribute("/", "source_size_bytes", static_cast<std::int64_t>(options.source_size));
    f.set_attribute("/", "point_count", static_cast<std::int64_t>(n));
    f.set_attribute("/", "tile_count", static_cast<std::int64_t>(tiling.tile_count()));
    f.create_group(layout::points);
    h5::DatasetOptions dopt;
    dopt.chunk_rows = std::min<std::uint64_t>(options.chunk_rows, std::max<std::uint64_t>(n, 1));
    dopt.deflate = options.deflate;

    h5::Dataset pos = f.create_dataset(layout::positions, h5::Type::Float64, n, 3, dopt);
    f.set_attribute(layout::positions, "source_type",
                    table.position_type == io::ScalarType::Float32 ? "float32" : "float64");
    write_source_format(f, table);
    h5::Dataset orig = f.create_dataset(layout::original_index, h5::Type::UInt64, n, 0, dopt);
    std::vector<double> block;
    std::vector<std::uint64_t> index_block;
    for (std::uint64_t first = 0; first < n; first += kBlockRows) {
      const std::uint64_t count = std::min(kBlockRows, n - first);
      block.resize(count * 3);
      for (std::uint64_t r = 0; r < count; ++r) {
        const Vec3& p = table.positions[tiling.order[first + r]];
        block[3 * r] = p.x();
        block[3 * r + 1] = p.y();
        block[3 * r + 2] = p.z();
      }
      pos.write_rows(first, count, block.data());
      orig.write_rows(first, count, tiling.order.data() + first);
    }
    f.create_group(layout::attributes);
    for (const auto& a : table.attributes) {
      const std::string path = std::string(layout::attributes) + "/" + a.name;
      h5::Dataset d = f.create_dataset(path, h5::to_h5(a.type), n, 0, dopt);
      for (std::uint64_t first = 0; first < n; first += kBlockRows) {
        const std::uint64_t count = std::min(kBlockRows, n - first);
        block.resize(count);
        for (std::uint64_t r = 0; r < count; ++r) block[r] = a.values[tiling.order[first + r]];
        d.write_rows(first, count, block.data());
      }
    }
    f.create_group(layout::tiles);
    f.set_attribute(layout::tiles, "scheme", options.tiling.cell_size > 0 ? "grid" : "kd");
    f.set_attribute(layout::tiles, "max_tile_points", static_cast<std::int64_t>(options.tiling.max_tile_points));
    f.set_attribute(layout::tiles, "cell_size", options.tiling.cell_size);
    h5::Dataset off = f.create_dataset(layout::tile_offsets, h5::Type::UInt64, tiling.offsets.size(), 0);
    off.write_rows(0, tiling.offsets.size(), tiling.offsets.data());
    h5::Dataset bnd = f.create_dataset(layout::tile_bounds, h5::Type::Float64, tiling.tile_count(), 6);
    bnd.write_rows(0, tiling.tile_count(), tiling.bounds.data()->data());
    f.flush();
    f.close();
    std::error_code ec;
    fs::rename(temp, file, ec);
    if (ec) throw io::IoError(file.string() + ": cannot rename the finished file into place: " + ec.message());
  } catch (const io::IoError& e) {
    throw naming_target(e, file);
  }
  remove_temp.path.clear();
}

std::uint64_t point_count(const h5::File& file) { return file.dataset(layout::positions).rows(); }

namespace {

// A dataset's shape sizes allocations only once its stored bytes can hold it: a hostile or
// corrupt shape (10^15 rows in a file of a few kilobytes: HDF5 allocates chunks lazily) must
// fail here, not in an allocation of petabytes. Deflate compresses at most ~1032:1.
void require_stored(const h5::File& file, const h5::Dataset& d) {
  const double claimed = static_cast<double>(d.rows()) * static_cast<double>(d.width()) *
                         static_cast<double>(d.element_bytes());
  const double stored = static_cast<double>(d.stored_bytes());
  if (claimed > 1032.0 * stored + 4096.0)
    file.fail(d.path(), "shape claims " + std::to_string(d.rows()) + " rows but the file stores only " +
                            std::to_string(d.stored_bytes()) + " bytes of them");
}

}  // namespace

Box cloud_bounds(const TileTable& tiles) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  Box all = {inf, inf, inf, -inf, -inf, -inf};
  for (const Box& b : tiles.bounds)
    for (std::size_t c = 0; c < 3; ++c) {
      all[c] = std::min(all[c], b[c]);
      all[c + 3] = std::max(all[c + 3], b[c + 3]);
    }
  return all;
}

TileTable read_tile_table(const h5::File& file) {
  if (!file.exists("/") || !file.has_attribute("/", "pointfair_format") ||
      file.string_attribute("/", "pointfair_format") != layout::format_name)
    file.fail("/", "not a pointfair container (no pointfair_format attribute)");
  const std::int64_t v = file.int_attribute("/", "format_version");
  if (v != layout::format_version)
    file.fail("/", "container format version " + std::to_string(v) + " is not supported (expected " +
                       std::to_string(layout::format_version) + ")");
  TileTable t;
  const h5::Dataset off = file.dataset(layout::tile_offsets);
  const h5::Dataset bnd = file.dataset(layout::tile_bounds);
  require_stored(file, off);
  require_stored(file, bnd);
  require_stored(file, file.dataset(layout::positions));  // the point count everything is sized by
  t.offsets = off.read_all<std::uint64_t>();
  if (bnd.width() != 6 || t.offsets.size() != bnd.rows() + 1)
    file.fail(layout::tile_bounds, "tile table shapes disagree");
  t.bounds.resize(bnd.rows());
  if (!t.bounds.empty()) bnd.read_rows(0, bnd.rows(), t.bounds.data()->data());
  const std::uint64_t n = point_count(file);
  if (t.offsets.front() != 0 || t.offsets.back() != n || !std::is_sorted(t.offsets.begin(), t.offsets.end()))
    file.fail(layout::tile_offsets, "tile offsets do not cover the points");
  return t;
}

bool has_finished_run(const h5::File& file) {
  if (!file.exists(layout::run_state)) return false;
  const auto state = file.dataset(layout::run_state).read_all<std::int64_t>();
  return state.size() >= 4 && state[3] == 1;
}

namespace {

// Rows [first, first + count) of `order` scattered into original positions, or in place.
template <class T>
void place(std::vector<T>& out, const std::vector<T>& block, std::uint64_t first, std::uint64_t width,
           const std::vector<std::uint64_t>* order) {
  const std::uint64_t count = block.size() / width;
  for (std::uint64_t r = 0; r < count; ++r) {
    const std::uint64_t to = order ? (*order)[first + r] : first + r;
    for (std::uint64_t c = 0; c < width; ++c) out[to * width + c] = block[r * width + c];
  }
}

std::vector<double> read_ordered(const h5::Dataset& d, const std::vector<std::uint64_t>* order) {
  const std::uint64_t n = d.rows(), w = d.width();
  std::vector<double> out(n * w), block;
  for (std::uint64_t first = 0; first < n; first += kBlockRows) {
    const std::uint64_t count = std::min(kBlockRows, n - first);
    block.resize(count * w);
    d.read_rows(first, count, block.data());
    place(out, block, first, w, order);
  }
  return out;
}

std::vector<std::uint64_t> read_order(const h5::File& f, std::uint64_t n) {
  std::vector<std::uint64_t> order = f.dataset(layout::original_index).read_all<std::uint64_t>();
  if (order.size() != n) f.fail(layout::original_index, "size differs from the positions");
  std::vector<bool> seen(n, false);
  for (const std::uint64_t i : order) {
    if (i >= n || seen[i]) f.fail(layout::original_index, "not a permutation of the rows");
    seen[i] = true;
  }
  return order;
}

std::vector<Vec3> to_vec3(const std::vector<double>& xyz) {
  std::vector<Vec3> v(xyz.size() / 3);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = Vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return v;
}

}  // namespace

io::PointTable read_container(const fs::path& file, const ReadContainerOptions& options) {
  const h5::File f = h5::File::open(file, false);
  read_tile_table(f);
  const std::uint64_t n = point_count(f);
  std::vector<std::uint64_t> order;
  if (options.original_order) order = read_order(f, n);
  const auto* ord = options.original_order ? &order : nullptr;
  std::string positions_path = layout::positions;
  if (options.result_positions && f.exists(layout::run_state)) {
    // A file of an interrupted run is never taken for a finished one.
    if (!has_finished_run(f))
      f.fail(layout::run_state, "the smoothing run in this file is unfinished: continue it with --resume "
                                "(or read the input positions)");
    positions_path = f.string_attribute(layout::run, "result_positions");
  }
  io::PointTable table;
  const h5::Dataset pos = f.dataset(positions_path);
  if (pos.width() != 3 || pos.rows() != n) f.fail(positions_path, "expected an [n, 3] array of positions");
  table.positions = to_vec3(read_ordered(pos, ord));
  table.position_type = f.has_attribute(layout::positions, "source_type") &&
                                f.string_attribute(layout::positions, "source_type") == "float32"
                            ? io::ScalarType::Float32
                            : io::ScalarType::Float64;
  read_source_format(f, table);
  if (f.exists(layout::attributes)) {
    for (const std::string& name : f.members(layout::attributes)) {
      const std::string path = std::string(layout::attributes) + "/" + name;
      const h5::Dataset d = f.dataset(path);
      if (d.rows() != n || d.width() != 1) f.fail(path, "expected one value per point");
      table.attributes.push_back({name, h5::to_scalar(d.type()), read_ordered(d, ord)});
      // The readers' rule (docs/hostile-inputs.md): attribute values are finite.
      for (std::size_t i = 0; i < table.attributes.back().values.size(); ++i)
        if (!std::isfinite(table.attributes.back().values[i]))
          f.fail(path, "value " + std::to_string(i) + " is not finite");
    }
  }
  return table;
}

PointAttributes read_run_attributes(const fs::path& file, bool original_order) {
  const h5::File f = h5::File::open(file, false);
  read_tile_table(f);
  if (!has_finished_run(f)) f.fail(layout::run, "no finished smoothing run in this file");
  if (!f.exists(std::string(layout::run_attributes) + "/k1")) f.fail(layout::run_attributes, "the run wrote no attributes");
  const std::uint64_t n = point_count(f);
  std::vector<std::uint64_t> order;
  if (original_order) order = read_order(f, n);
  const auto* ord = original_order ? &order : nullptr;
  auto column = [&](const char* name) {
    return read_ordered(f.dataset(std::string(layout::run_attributes) + "/" + name), ord);
  };
  PointAttributes a;
  a.normal = to_vec3(column("normal"));
  a.d1 = to_vec3(column("d1"));
  a.d2 = to_vec3(column("d2"));
  a.k1 = column("k1");
  a.k2 = column("k2");
  a.mean_curvature = column("mean_curvature");
  a.laplacian_norm = column("laplacian_norm");
  const std::vector<double> feature = column("feature_class");
  a.feature.resize(feature.size());
  for (std::size_t i = 0; i < feature.size(); ++i) a.feature[i] = static_cast<FeatureClass>(static_cast<int>(feature[i]));
  if (f.has_attribute(layout::run_attributes, "degenerate"))
    a.degenerate = static_cast<std::size_t>(f.int_attribute(layout::run_attributes, "degenerate"));
  return a;
}

bool is_container_path(const fs::path& path) {
  std::string e = path.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e == ".h5" || e == ".hdf5";
}

}  // namespace pointfair::tiles
