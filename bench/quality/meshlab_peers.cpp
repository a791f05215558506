#include "meshlab_peers.hpp"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "pointfair/io/ply.hpp"

namespace fs = std::filesystem;

namespace pointfair::quality {

namespace {

bool on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return false;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    std::error_code ec;
    if (!dir.empty() && fs::is_regular_file(fs::path(dir) / program, ec)) return true;
  }
  return false;
}

// The filter and parameter names are MeshLab 2020.09's (from `meshlabserver -d` for the
// filter names and the filter plugins for the parameter names); meshlabserver aborts when a
// filter's parameter list is incomplete, so every parameter is given.
std::string script_of(const MeshlabMlsParams& p) {
  std::ostringstream s;
  s << "<!DOCTYPE FilterScript>\n<FilterScript>\n"
    << " <filter name=\"Compute normals for point sets\">\n"
    << "  <Param type=\"RichInt\" name=\"K\" value=\"" << p.normal_k << "\"/>\n"
    << "  <Param type=\"RichInt\" name=\"smoothIter\" value=\"0\"/>\n"
    << "  <Param type=\"RichBool\" name=\"flipFlag\" value=\"false\"/>\n"
    << "  <Param type=\"RichPoint3f\" name=\"viewPos\" x=\"0\" y=\"0\" z=\"0\"/>\n"
    << " </filter>\n";
  const bool rimls = p.variant == MeshlabMls::Rimls;
  s << " <filter name=\"MLS projection (" << (rimls ? "RIMLS" : "APSS") << ")\">\n"
    << "  <Param type=\"RichMesh\" name=\"ControlMesh\" value=\"0\"/>\n"
    << "  <Param type=\"RichMesh\" name=\"ProxyMesh\" value=\"0\"/>\n"
    << "  <Param type=\"RichBool\" name=\"SelectionOnly\" value=\"false\"/>\n"
    << "  <Param type=\"RichFloat\" name=\"FilterScale\" value=\"" << p.filter_scale << "\"/>\n"
    << "  <Param type=\"RichFloat\" name=\"ProjectionAccuracy\" value=\"0.0001\"/>\n"
    << "  <Param type=\"RichInt\" name=\"MaxProjectionIters\" value=\"15\"/>\n";
  if (rimls)
    s << "  <Param type=\"RichFloat\" name=\"SigmaN\" value=\"" << p.sigma_n << "\"/>\n"
      << "  <Param type=\"RichInt\" name=\"MaxRefittingIters\" value=\"3\"/>\n";
  else
    s << "  <Param type=\"RichFloat\" name=\"SphericalParameter\" value=\"" << p.spherical << "\"/>\n"
      << "  <Param type=\"RichBool\" name=\"AccurateNormal\" value=\"true\"/>\n";
  s << "  <Param type=\"RichInt\" name=\"MaxSubdivisions\" value=\"0\"/>\n"
    << "  <Param type=\"RichFloat\" name=\"ThAngleInDegree\" value=\"2\"/>\n"
    << " </filter>\n</FilterScript>\n";
  return s.str();
}

// MeshLab's output cloud: binary little-endian PLY, scalar vertex properties. Its own reader
// because the project's read_ply refuses non-finite coordinates, and MeshLab writes NaN for
// a point whose projection failed.
struct MeshlabCloud {
  std::vector<Vec3> positions;
  std::vector<double> quality;
};

MeshlabCloud read_meshlab_ply(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  const auto fail = [&](const std::string& problem) { return std::runtime_error(file.string() + ": " + problem); };
  std::string line;
  std::size_t count = 0;
  bool in_vertex = false, binary_le = false;
  struct Property {
    std::string name;
    std::size_t size;
    char kind;  // 'i' signed, 'u' unsigned, 'f' floating
  };
  std::vector<Property> properties;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "format") {
      std::string format;
      words >> format;
      binary_le = format == "binary_little_endian";
    } else if (word == "element") {
      std::string name;
      words >> name;
      in_vertex = name == "vertex";
      if (in_vertex) words >> count;
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      words >> type >> name;
      if (type == "list") throw fail("list property in the vertex element");
      static const std::vector<std::tuple<std::string, std::size_t, char>> types{
          {"char", 1, 'i'},  {"int8", 1, 'i'},   {"uchar", 1, 'u'}, {"uint8", 1, 'u'},   {"short", 2, 'i'},
          {"int16", 2, 'i'}, {"ushort", 2, 'u'}, {"uint16", 2, 'u'}, {"int", 4, 'i'},    {"int32", 4, 'i'},
          {"uint", 4, 'u'},  {"uint32", 4, 'u'}, {"float", 4, 'f'},  {"float32", 4, 'f'}, {"double", 8, 'f'},
          {"float64", 8, 'f'}};
      bool known = false;
      for (const auto& [t, size, kind] : types)
        if (t == type) {
          properties.push_back({name, size, kind});
          known = true;
        }
      if (!known) throw fail("unknown property type " + type);
    } else if (word == "end_header") {
      break;
    }
  }
  if (!binary_le) throw fail("not a binary little-endian PLY");
  std::size_t stride = 0;
  for (const auto& p : properties) stride += p.size;
  std::vector<unsigned char> data(count * stride);
  if (!in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size())))
    throw fail("truncated vertex data");
  const auto value = [](const unsigned char* at, const Property& p) -> double {
    if (p.kind == 'f') {
      if (p.size == 4) {
        float v;
        std::memcpy(&v, at, 4);
        return v;
      }
      double v;
      std::memcpy(&v, at, 8);
      return v;
    }
    std::uint64_t bits = 0;
    for (std::size_t b = 0; b < p.size; ++b) bits |= static_cast<std::uint64_t>(at[b]) << (8 * b);
    if (p.kind == 'u') return static_cast<double>(bits);
    const std::uint64_t sign = std::uint64_t{1} << (8 * p.size - 1);
    return static_cast<double>(static_cast<std::int64_t>((bits ^ sign) - sign));
  };
  MeshlabCloud cloud;
  cloud.positions.resize(count, Vec3::Zero());
  cloud.quality.assign(count, -1.0);
  for (std::size_t i = 0; i < count; ++i) {
    const unsigned char* at = data.data() + i * stride;
    for (const auto& p : properties) {
      const double v = value(at, p);
      if (p.name == "x") cloud.positions[i].x() = v;
      else if (p.name == "y") cloud.positions[i].y() = v;
      else if (p.name == "z") cloud.positions[i].z() = v;
      else if (p.name == "quality") cloud.quality[i] = v;
      at += p.size;
    }
  }
  return cloud;
}

std::string quoted(const fs::path& p) {
  std::string out = "'";
  for (const char c : p.string()) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

bool meshlab_available() { return on_path("meshlabserver") && on_path("xvfb-run"); }

MeshlabResult meshlab_mls(const std::vector<Vec3>& points, const MeshlabMlsParams& params, const fs::path& work_dir) {
  fs::create_directories(work_dir);
  const fs::path in = work_dir / "in.ply", out = work_dir / "out.ply", script = work_dir / "script.mlx",
                 log = work_dir / "meshlab.log";
  // MeshLab reads float coordinates: the cloud is centred first, as for PCL.
  Vec3 centre = Vec3::Zero();
  for (const Vec3& p : points) centre += p;
  if (!points.empty()) centre /= static_cast<double>(points.size());
  io::PointTable table;
  table.position_type = io::ScalarType::Float32;
  table.positions.reserve(points.size());
  std::vector<double> index(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    table.positions.push_back(points[i] - centre);
    index[i] = static_cast<double>(i);
  }
  table.set("quality", io::ScalarType::Float32, std::move(index));
  io::write_ply(in, table, io::PlyEncoding::BinaryLittleEndian);
  std::ofstream(script) << script_of(params);
  fs::remove(out);
  const std::string command = "xvfb-run -a meshlabserver -i " + quoted(in) + " -o " + quoted(out) + " -m vq -s " +
                              quoted(script) + " > " + quoted(log) + " 2>&1";
  const int status = std::system(command.c_str());
  if (status != 0 || !fs::exists(out))
    throw std::runtime_error("meshlabserver failed (status " + std::to_string(status) + "), see " + log.string());
  const MeshlabCloud result = read_meshlab_ply(out);

  MeshlabResult r;
  r.points = points;
  std::vector<char> placed(points.size(), 0);
  for (std::size_t k = 0; k < result.positions.size(); ++k) {
    const double q = result.quality[k];
    if (!(q >= 0.0) || q >= static_cast<double>(points.size()) || q != std::floor(q)) continue;
    const auto i = static_cast<std::size_t>(q);
    if (i != k) ++r.moved_in_order;
    if (!result.positions[k].allFinite()) {
      ++r.failed;
      continue;
    }
    r.points[i] = centre + result.positions[k];
    placed[i] = 1;
  }
  for (const char p : placed) r.kept_input += p ? 0 : 1;
  return r;
}

}  // namespace pointfair::quality
