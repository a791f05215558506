// Ground-truth surfaces: analytic closest points where the shape is analytic, an indexed
// triangle mesh otherwise. Signs of mesh distances come from angle-weighted pseudo-normals
// (vertex) and summed face normals (edge), which give the correct side of a closed mesh for
// every closest-point region.
#include "pointfair/eval/truth.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <unordered_map>

#include "pointfair/common/params_error.hpp"
#include "pointfair/eval/aabb_tree.hpp"
#include "pointfair/eval/metrics.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/io/mesh.hpp"
#include "pointfair/io/point_table.hpp"
#include "pointfair/neighbors/kd_tree.hpp"
#include "pointfair/shapes/mesh_distance.hpp"

namespace pointfair::eval {

namespace fs = std::filesystem;

struct GroundTruth::Surface {
  TruthSpec spec;
  virtual ~Surface() = default;
  virtual SurfacePoint closest(const Vec3& p) const = 0;
  virtual bool has_creases() const { return false; }
  virtual Eigen::AlignedBox3d bounds() const = 0;
  virtual SurfaceSamples sample(std::size_t count, std::uint64_t seed) const = 0;
  virtual const TriangleMesh* mesh() const { return nullptr; }
  virtual std::size_t sharp_edges() const { return 0; }
};

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::uint64_t edge_key(Index a, Index b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

class MeshSurface final : public GroundTruth::Surface {
 public:
  MeshSurface(TriangleMesh mesh, bool flat_faces, double sharp_angle_degrees)
      : mesh_(std::move(mesh)), flat_faces_(flat_faces) {
    require(!mesh_.triangles.empty(), "ground-truth mesh has no triangles");
    for (std::size_t v = 0; v < mesh_.vertices.size(); ++v)
      require(mesh_.vertices[v].cwiseAbs().maxCoeff() <= kEvalMaxCoordinate,
              "vertex " + std::to_string(v) +
                  " has a coordinate beyond 1e100 in magnitude, where squared distances overflow: rescale the mesh");
    const std::size_t nt = mesh_.triangles.size();
    face_normals_.resize(nt);
    std::vector<Eigen::AlignedBox3d> boxes(nt);
    vertex_normals_.assign(mesh_.vertices.size(), Vec3::Zero());
    std::unordered_map<std::uint64_t, std::vector<Index>> edge_faces;
    edge_faces.reserve(nt * 2);
    for (std::size_t f = 0; f < nt; ++f) {
      const auto& t = mesh_.triangles[f];
      const Vec3 &a = mesh_.vertices[t[0]], &b = mesh_.vertices[t[1]], &c = mesh_.vertices[t[2]];
      const Vec3 n = (b - a).cross(c - a);
      face_normals_[f] = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(Vec3::Zero());
      boxes[f].extend(a).extend(b).extend(c);
      for (int k = 0; k < 3; ++k) {
        const Vec3& v = mesh_.vertices[t[k]];
        const Vec3 e1 = mesh_.vertices[t[(k + 1) % 3]] - v, e2 = mesh_.vertices[t[(k + 2) % 3]] - v;
        const double denom = e1.norm() * e2.norm();
        const double angle = denom > 0 ? std::acos(std::clamp(e1.dot(e2) / denom, -1.0, 1.0)) : 0.0;
        vertex_normals_[t[k]] += angle * face_normals_[f];
        edge_faces[edge_key(t[k], t[(k + 1) % 3])].push_back(static_cast<Index>(f));
      }
    }
    tree_ = AabbTree(boxes);
    const double cos_sharp = std::cos(sharp_angle_degrees * std::numbers::pi / 180.0);
    std::vector<Eigen::AlignedBox3d> edge_boxes;
    for (const auto& [key, faces] : edge_faces) {
      Vec3 sum = Vec3::Zero();
      bool sharp = false;
      for (std::size_t i = 0; i < faces.size(); ++i) {
        sum += face_normals_[faces[i]];
        for (std::size_t j = i + 1; j < faces.size(); ++j)
          sharp = sharp || face_normals_[faces[i]].dot(face_normals_[faces[j]]) < cos_sharp;
      }
      edge_normals_.emplace(key, sum);
      if (sharp) {
        const Vec3& a = mesh_.vertices[static_cast<Index>(key >> 32)];
        const Vec3& b = mesh_.vertices[static_cast<Index>(key & 0xffffffffu)];
        sharp_.push_back({a, b});
      }
    }
    // Deterministic order of the sharp edges (the hash map's order is not).
    std::sort(sharp_.begin(), sharp_.end(), [](const auto& x, const auto& y) {
      return std::lexicographical_compare(x[0].data(), x[0].data() + 3, y[0].data(), y[0].data() + 3) ||
             (x[0] == y[0] && std::lexicographical_compare(x[1].data(), x[1].data() + 3, y[1].data(), y[1].data() + 3));
    });
    for (const auto& s : sharp_) {
      Eigen::AlignedBox3d box;
      box.extend(s[0]).extend(s[1]);
      edge_boxes.push_back(box);
    }
    edge_tree_ = AabbTree(edge_boxes);
    for (const Vec3& v : mesh_.vertices) bounds_.extend(v);
  }

  SurfacePoint closest(const Vec3& p) const override {
    Vec3 q_best = p;
    const auto [f, d2] = tree_.nearest(p, [&](Index i) {
      const auto& t = mesh_.triangles[i];
      return (p - closest_point_on_triangle(p, mesh_.vertices[t[0]], mesh_.vertices[t[1]], mesh_.vertices[t[2]]))
          .squaredNorm();
    });
    const auto& t = mesh_.triangles[f];
    const Vec3 &a = mesh_.vertices[t[0]], &b = mesh_.vertices[t[1]], &c = mesh_.vertices[t[2]];
    q_best = closest_point_on_triangle(p, a, b, c);
    SurfacePoint s;
    s.point = q_best;
    s.normal = face_normals_[f];
    // Barycentric coordinates of q decide the region: face, edge or vertex.
    const Vec3 v0 = b - a, v1 = c - a, v2 = q_best - a;
    const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
    const double denom = d00 * d11 - d01 * d01;
    double w[3] = {1.0, 0.0, 0.0};
    if (denom > 0) {
      w[1] = (d11 * d20 - d01 * d21) / denom;
      w[2] = (d00 * d21 - d01 * d20) / denom;
      w[0] = 1.0 - w[1] - w[2];
    }
    constexpr double tol = 1e-9;
    int zeros = 0, nonzero[3], nz = 0;
    for (int k = 0; k < 3; ++k) {
      if (std::abs(w[k]) <= tol) ++zeros;
      else nonzero[nz++] = k;
    }
    Vec3 pseudo = face_normals_[f];
    if (zeros == 1) {
      pseudo = edge_normals_.at(edge_key(t[nonzero[0]], t[nonzero[1]]));
    } else if (zeros == 2) {
      pseudo = vertex_normals_[t[nonzero[0]]];
    }
    const double dist = std::sqrt(d2);
    s.signed_distance = (p - q_best).dot(pseudo) < 0 ? -dist : dist;
    if (!edge_tree_.empty()) {
      const auto nearest_edge = edge_tree_.nearest(q_best, [&](Index i) {
        const double e = distance_to_segment(q_best, sharp_[i][0], sharp_[i][1]);
        return e * e;
      });
      s.crease_distance = std::sqrt(nearest_edge.second);
    }
    s.has_curvature = flat_faces_;
    return s;
  }
  bool has_creases() const override { return !sharp_.empty(); }
  Eigen::AlignedBox3d bounds() const override { return bounds_; }
  SurfaceSamples sample(std::size_t count, std::uint64_t seed) const override {
    return sample_mesh(mesh_, count, seed);
  }
  const TriangleMesh* mesh() const override { return &mesh_; }
  std::size_t sharp_edges() const override { return sharp_.size(); }

 private:
  TriangleMesh mesh_;
  bool flat_faces_;
  std::vector<Vec3> face_normals_;
  std::vector<Vec3> vertex_normals_;
  std::unordered_map<std::uint64_t, Vec3> edge_normals_;
  std::vector<std::array<Vec3, 2>> sharp_;
  AabbTree tree_, edge_tree_;
  Eigen::AlignedBox3d bounds_;
};

class SphereSurface final : public GroundTruth::Surface {
 public:
  SurfacePoint closest(const Vec3& p) const override {
    const double r = spec.radius, len = p.norm();
    SurfacePoint s;
    s.normal = len > 0 ? Vec3(p / len) : Vec3(Vec3::UnitZ());
    s.point = r * s.normal;
    s.signed_distance = len - r;
    s.k1 = s.k2 = 1.0 / r;
    s.has_curvature = true;
    return s;
  }
  Eigen::AlignedBox3d bounds() const override {
    return {Vec3::Constant(-spec.radius), Vec3::Constant(spec.radius)};
  }
  SurfaceSamples sample(std::size_t count, std::uint64_t seed) const override {
    return sample_sphere(count, spec.radius, seed);
  }
};

// Side of the cylinder x^2 + y^2 = radius^2, |z| <= length / 2 (as sample_cylinder).
class CylinderSurface final : public GroundTruth::Surface {
 public:
  SurfacePoint closest(const Vec3& p) const override {
    const double r = spec.radius, h = spec.length / 2;
    Vec3 radial(p.x(), p.y(), 0.0);
    radial = radial.norm() > 0 ? Vec3(radial.normalized()) : Vec3(Vec3::UnitX());
    SurfacePoint s;
    s.normal = radial;
    s.point = r * radial + Vec3(0, 0, std::clamp(p.z(), -h, h));
    const double dist = (p - s.point).norm();
    s.signed_distance = (p - s.point).dot(radial) < 0 ? -dist : dist;
    s.k1 = 1.0 / r;
    s.k2 = 0.0;
    s.has_curvature = true;
    return s;
  }
  Eigen::AlignedBox3d bounds() const override {
    return {Vec3(-spec.radius, -spec.radius, -spec.length / 2), Vec3(spec.radius, spec.radius, spec.length / 2)};
  }
  SurfaceSamples sample(std::size_t count, std::uint64_t seed) const override {
    return sample_cylinder(count, spec.radius, spec.length, seed);
  }
};

class TorusSurface final : public GroundTruth::Surface {
 public:
  SurfacePoint closest(const Vec3& p) const override {
    const double big = spec.major, small = spec.minor;
    Vec3 ring(p.x(), p.y(), 0.0);
    ring = (ring.norm() > 0 ? Vec3(ring.normalized()) : Vec3(Vec3::UnitX())) * big;
    const Vec3 d = p - ring;
    SurfacePoint s;
    s.normal = d.norm() > 0 ? Vec3(d.normalized()) : Vec3(ring.normalized());
    s.point = ring + small * s.normal;
    s.signed_distance = d.norm() - small;
    const double cos_v = s.normal.dot(ring.normalized());
    const double ka = 1.0 / small, kb = cos_v / (big + small * cos_v);
    s.k1 = std::max(ka, kb);
    s.k2 = std::min(ka, kb);
    s.has_curvature = true;
    return s;
  }
  Eigen::AlignedBox3d bounds() const override {
    const double e = spec.major + spec.minor;
    return {Vec3(-e, -e, -spec.minor), Vec3(e, e, spec.minor)};
  }
  SurfaceSamples sample(std::size_t count, std::uint64_t seed) const override {
    return sample_torus(count, spec.major, spec.minor, seed);
  }
};

// sample_cylinder_plane's union: cylinder y^2 + z^2 = r^2 and plane z = 0, |x| <= L/2.
class CylinderPlaneSurface final : public GroundTruth::Surface {
 public:
  SurfacePoint closest(const Vec3& p) const override {
    const double r = spec.radius, hl = spec.length / 2, hw = spec.width / 2;
    const double x = std::clamp(p.x(), -hl, hl);
    Vec3 radial(0.0, p.y(), p.z());
    radial = radial.norm() > 0 ? Vec3(radial.normalized()) : Vec3(Vec3::UnitZ());
    const Vec3 qc = Vec3(x, 0, 0) + r * radial;
    const Vec3 qp(x, std::clamp(p.y(), -hw, hw), 0.0);
    SurfacePoint s;
    const bool on_cylinder = (p - qc).squaredNorm() <= (p - qp).squaredNorm();
    s.point = on_cylinder ? qc : qp;
    s.normal = on_cylinder ? radial : Vec3(Vec3::UnitZ());
    const double dist = (p - s.point).norm();
    s.signed_distance = (p - s.point).dot(s.normal) < 0 ? -dist : dist;
    s.k1 = on_cylinder ? 1.0 / r : 0.0;
    s.k2 = 0.0;
    s.has_curvature = true;
    s.crease_distance = std::min(distance_to_segment(s.point, Vec3(-hl, r, 0), Vec3(hl, r, 0)),
                                 distance_to_segment(s.point, Vec3(-hl, -r, 0), Vec3(hl, -r, 0)));
    return s;
  }
  bool has_creases() const override { return true; }
  Eigen::AlignedBox3d bounds() const override {
    const double hy = std::max(spec.radius, spec.width / 2);
    return {Vec3(-spec.length / 2, -hy, -spec.radius), Vec3(spec.length / 2, hy, spec.radius)};
  }
  SurfaceSamples sample(std::size_t count, std::uint64_t seed) const override {
    return sample_cylinder_plane(count, spec.radius, spec.length, spec.width, seed);
  }
};

// Enneper's surface over the parameter disc of radius `extent`: closest point by Gauss-Newton
// on (u, v), started from the nearest point of a dense parameter grid.
class EnneperSurface final : public GroundTruth::Surface {
 public:
  explicit EnneperSurface(const TruthSpec& s) {
    spec = s;
    require(spec.extent > 0 && spec.extent < std::sqrt(3.0), "Enneper extent must be in (0, sqrt 3)");
    constexpr int n = 301;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const double u = spec.extent * (2.0 * i / (n - 1) - 1.0), v = spec.extent * (2.0 * j / (n - 1) - 1.0);
        if (u * u + v * v > spec.extent * spec.extent) continue;
        uv_.emplace_back(u, v);
        grid_.push_back(enneper_point(u, v));
        bounds_.extend(grid_.back());
      }
    tree_ = std::make_unique<KdTree>(grid_);
  }
  SurfacePoint closest(const Vec3& p) const override {
    Index nearest = 0;
    double d2 = 0;
    tree_->nearest(p, 1, kInf, &nearest, &d2);
    double u = uv_[nearest].x(), v = uv_[nearest].y();
    for (int it = 0; it < 20; ++it) {
      const Vec3 xu(1.0 - u * u + v * v, 2.0 * u * v, 2.0 * u);
      const Vec3 xv(2.0 * u * v, 1.0 - v * v + u * u, -2.0 * v);
      const Vec3 r = p - enneper_point(u, v);
      Eigen::Matrix2d jtj;
      jtj << xu.dot(xu), xu.dot(xv), xu.dot(xv), xv.dot(xv);
      const Eigen::Vector2d step = jtj.ldlt().solve(Eigen::Vector2d(xu.dot(r), xv.dot(r)));
      u += step.x();
      v += step.y();
      const double rr = std::hypot(u, v);
      if (rr > spec.extent) {
        u *= spec.extent / rr;
        v *= spec.extent / rr;
      }
      if (step.norm() < 1e-13) break;
    }
    SurfacePoint s;
    s.point = enneper_point(u, v);
    s.normal = enneper_normal(u, v);
    const double dist = (p - s.point).norm();
    s.signed_distance = (p - s.point).dot(s.normal) < 0 ? -dist : dist;
    const double w = 1.0 + u * u + v * v;
    s.k1 = 2.0 / (w * w);
    s.k2 = -s.k1;
    s.has_curvature = true;
    return s;
  }
  Eigen::AlignedBox3d bounds() const override { return bounds_; }
  SurfaceSamples sample(std::size_t count, std::uint64_t seed) const override {
    return sample_enneper(count, spec.extent, seed);
  }

 private:
  std::vector<Eigen::Vector2d> uv_;
  std::vector<Vec3> grid_;
  std::unique_ptr<KdTree> tree_;
  Eigen::AlignedBox3d bounds_;
};

[[noreturn]] void fail_file(const fs::path& file, const std::string& problem) {
  throw io::IoError(file.string() + ": " + problem);
}

}  // namespace

TruthSpec read_truth_file(const fs::path& file) {
  io::require_regular_input(file);  // a named pipe would block the open
  std::ifstream in(file);
  if (!in) fail_file(file, "cannot open");
  std::string line;
  if (!std::getline(in, line) || line.rfind("pointfair-truth 1", 0) != 0)
    fail_file(file, "not a truth file (first line must be 'pointfair-truth 1')");
  TruthSpec spec;
  bool have_shape = false;
  int number = 1;
  while (std::getline(in, line)) {
    ++number;
    std::istringstream words(line);
    std::string key;
    if (!(words >> key) || key[0] == '#') continue;
    std::string rest;
    std::getline(words >> std::ws, rest);
    auto value = [&]() {
      try {
        std::size_t used = 0;
        const double v = std::stod(rest, &used);
        if (used == 0 || !std::isfinite(v)) throw std::invalid_argument("");
        return v;
      } catch (const std::exception&) {
        fail_file(file, "line " + std::to_string(number) + ": '" + key + "' needs a number");
      }
    };
    if (key == "shape") {
      spec.shape = rest;
      have_shape = true;
    } else if (key == "radius") spec.radius = value();
    else if (key == "major") spec.major = value();
    else if (key == "minor") spec.minor = value();
    else if (key == "length") spec.length = value();
    else if (key == "width") spec.width = value();
    else if (key == "extent") spec.extent = value();
    else if (key == "mesh") {
      fs::path mesh(rest);
      spec.mesh = mesh.is_absolute() ? mesh : file.parent_path() / mesh;
    } else fail_file(file, "line " + std::to_string(number) + ": unknown key '" + key + "'");
  }
  if (!have_shape) fail_file(file, "no 'shape' line");
  return spec;
}

void write_truth_file(const fs::path& file, const TruthSpec& spec) {
  std::ostringstream text;
  text.precision(17);
  text << "pointfair-truth 1\nshape " << spec.shape << "\n";
  if (spec.shape == "sphere") text << "radius " << spec.radius << "\n";
  if (spec.shape == "cylinder") text << "radius " << spec.radius << "\nlength " << spec.length << "\n";
  if (spec.shape == "torus") text << "major " << spec.major << "\nminor " << spec.minor << "\n";
  if (spec.shape == "cylinder-plane")
    text << "radius " << spec.radius << "\nlength " << spec.length << "\nwidth " << spec.width << "\n";
  if (spec.shape == "enneper") text << "extent " << spec.extent << "\n";
  if (spec.shape == "mesh") text << "mesh " << spec.mesh.string() << "\n";
  io::write_file_atomically(file, [&](io::FileSink& sink) { sink.write(text.str()); });
}

TruthSpec truth_from_argument(const std::string& argument) {
  const fs::path path(argument);
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".truth") return read_truth_file(path);
  TruthSpec spec;
  if (ext == ".off" || ext == ".ply") {
    spec.shape = "mesh";
    spec.mesh = path;
    return spec;
  }
  spec.shape = argument;
  if (spec.shape == "cylinder") spec.length = 2.0;
  return spec;
}

GroundTruth::GroundTruth(const TruthSpec& spec, const TruthParams& params) {
  require(params.sharp_angle_degrees > 0 && params.sharp_angle_degrees < 180, "sharp angle must be in (0, 180) degrees");
  const std::string& s = spec.shape;
  if (s == "cube") surface_ = std::make_unique<MeshSurface>(cube_mesh(), true, params.sharp_angle_degrees);
  else if (s == "octahedron") surface_ = std::make_unique<MeshSurface>(octahedron_mesh(), true, params.sharp_angle_degrees);
  else if (s == "truncated-octahedron")
    surface_ = std::make_unique<MeshSurface>(truncated_octahedron_mesh(), true, params.sharp_angle_degrees);
  else if (s == "mesh") surface_ = std::make_unique<MeshSurface>(io::read_mesh(spec.mesh), false, params.sharp_angle_degrees);
  else if (s == "sphere") surface_ = std::make_unique<SphereSurface>();
  else if (s == "cylinder") surface_ = std::make_unique<CylinderSurface>();
  else if (s == "torus") surface_ = std::make_unique<TorusSurface>();
  else if (s == "cylinder-plane") surface_ = std::make_unique<CylinderPlaneSurface>();
  else if (s == "enneper") surface_ = std::make_unique<EnneperSurface>(spec);
  else
    throw ParamError("unknown shape '" + s +
                     "' (cube, octahedron, truncated-octahedron, sphere, cylinder, torus, cylinder-plane, enneper, mesh)");
  require(spec.radius > 0 && spec.length > 0 && spec.width > 0, "shape sizes must be > 0");
  require(s != "torus" || (spec.major > spec.minor && spec.minor > 0), "torus radii must satisfy major > minor > 0");
  surface_->spec = spec;
}

GroundTruth::~GroundTruth() = default;
GroundTruth::GroundTruth(GroundTruth&&) noexcept = default;
GroundTruth& GroundTruth::operator=(GroundTruth&&) noexcept = default;

SurfacePoint GroundTruth::closest(const Vec3& p) const { return surface_->closest(p); }
bool GroundTruth::has_creases() const { return surface_->has_creases(); }
Eigen::AlignedBox3d GroundTruth::bounds() const { return surface_->bounds(); }
SurfaceSamples GroundTruth::sample(std::size_t count, std::uint64_t seed) const {
  return surface_->sample(count, seed);
}
const TruthSpec& GroundTruth::spec() const { return surface_->spec; }
const TriangleMesh* GroundTruth::mesh() const { return surface_->mesh(); }
std::size_t GroundTruth::sharp_edge_count() const { return surface_->sharp_edges(); }

SurfaceSamples generate_clean_samples(const TruthSpec& spec, std::size_t count, std::uint64_t seed) {
  if (spec.shape == "octahedron") {
    int level = 0;
    const auto n = static_cast<double>(count);
    while (level < 10 && std::abs(std::pow(4.0, level + 2) + 2 - n) < std::abs(std::pow(4.0, level + 1) + 2 - n)) ++level;
    return mesh_vertices(subdivide_4_1(octahedron_mesh(), level));
  }
  return GroundTruth(spec).sample(count, seed);
}

}  // namespace pointfair::eval
