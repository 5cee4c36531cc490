#include "discretizations/triangle_shell/triangle_shell.hpp"

#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <sstream>

#include "core/config.hpp"
#include "core/input_error.hpp"
#include "discretizations/assembly/block_scatter.hpp"
#include "discretizations/assembly/element_nodes.hpp"
#include "discretizations/assembly/element_schedule.hpp"
#include "discretizations/assembly/element_scratch.hpp"
#include "discretizations/assembly/hessian_pattern.hpp"
#include "discretizations/assembly/nodal_gravity.hpp"
#include "discretizations/assembly/parallel_runner.hpp"
#include "discretizations/triangle_shell/constant_strain_triangle.hpp"
#include "discretizations/triangle_shell/strip_triangulation.hpp"

namespace twill {

std::string to_string(StripEnds ends) {
  switch (ends) {
    case StripEnds::None: return "none";
    case StripEnds::Start: return "start";
    case StripEnds::End: return "end";
    case StripEnds::Both: return "both";
  }
  return "none";
}

std::vector<StripEnds> all_strip_ends() {
  return {StripEnds::None, StripEnds::Start, StripEnds::End, StripEnds::Both};
}

StripEnds strip_ends_from_string(const std::string& text) {
  for (StripEnds e : all_strip_ends())
    if (to_string(e) == text) return e;
  throw InputError({"", 0, "clamp_hinges"},
                   "unknown strip ends '" + text + "' (known: none, start, end, both)");
}

bool includes(StripEnds ends, StripEnd end) {
  return ends == StripEnds::Both || (end == StripEnd::Start && ends == StripEnds::Start) ||
         (end == StripEnd::End && ends == StripEnds::End);
}

std::string to_string(HingeModel model) {
  switch (model) {
    case HingeModel::ShapeOperator: return "shape-operator";
    case HingeModel::Directional: return "directional";
    case HingeModel::Cylinders: return "cylinders";
  }
  return "?";
}

std::vector<HingeModel> all_hinge_models() {
  return {HingeModel::ShapeOperator, HingeModel::Directional, HingeModel::Cylinders};
}

HingeModel hinge_model_from_string(const std::string& text) {
  for (HingeModel m : all_hinge_models())
    if (to_string(m) == text) return m;
  throw InputError({"", 0, "hinge_model"}, "unknown hinge model '" + text +
                                               "' (known: shape-operator, directional, cylinders)");
}

OptionBindings<TriangleShellOptions> triangle_shell_option_bindings() {
  using O = TriangleShellOptions;
  std::vector<std::pair<std::string, TrianglePattern>> patterns;
  for (TrianglePattern p : all_triangle_patterns()) patterns.emplace_back(to_string(p), p);
  std::vector<std::pair<std::string, StripEnds>> ends;
  for (StripEnds e : all_strip_ends()) ends.emplace_back(to_string(e), e);
  std::vector<std::pair<std::string, HingeModel>> models;
  for (HingeModel m : all_hinge_models()) models.emplace_back(to_string(m), m);
  return {
      enum_option<O>("pattern", &O::pattern, patterns, "how each cell is split into triangles"),
      // Offsets of a quarter cell can invert triangles.
      real_option<O>("perturbation", &O::perturbation,
                     "irregular pattern: largest vertex offset as a fraction of the cell size",
                     [](OptionSpec& s) { s.at_least(0.0).less_than(0.25); }),
      integer_option<O>("seed", &O::seed, "irregular pattern: random seed"),
      integer_option<O>("threads", &O::threads, "assembly threads (0 = TBB's choice, 1 = serial)",
                        at_least(0)),
      enum_option<O>("clamp_hinges", &O::clamp_hinges, ends,
                     "ends whose slope clamp is a hinge against the rest plane instead of a rigid "
                     "first cell column (cantilever: start)"),
      enum_option<O>("hinge_model", &O::hinge_model, models,
                     "bending model: shape-operator (per-triangle curvature from the hinge angles "
                     "with the law's KL bending energy; exact for every uniform curvature, no "
                     "mesh-scale modes), or hinge energies: directional (plate stiffness across "
                     "each edge) or cylinders (per class, warp/weft/45° exact, soft diagonal folds)"),
  };
}

bool TriangleShellOptions::validate(std::string* error) const {
  return check_options(triangle_shell_option_bindings(), *this, error);
}

namespace {

// Assembly slabs (see Impl::slabs) are at least this many cell columns wide (an element spans
// at most 2 columns, so slabs of one parity never share a vertex), and there are at most this
// many of them: enough tasks to balance a few threads, few enough that each is real work.
constexpr int kMinSlabColumns = 3;
constexpr int kMaxSlabs = 16;
// Energy-only calls go parallel from this many elements on (below, scheduling costs more).
constexpr int kParallelMinimum = 1024;
// Chunk of an independent loop (energy-only elements, angles, faces).
constexpr int kGrain = 64;
// Point location widens each triangle's bounding box by this fraction of a cell, so that a
// point on an edge shared by two triangles finds both.
constexpr double kPointLocationSlack = 1e-9;


void validate_strip(const StripSpec& s) {
  auto fail = [](const std::string& key, const std::string& what) {
    throw InputError({"", 0, key}, what);
  };
  if (!(s.length_m > 0.0 && std::isfinite(s.length_m)))
    fail("strip.length_m", "strip length must be positive, got " + std::to_string(s.length_m));
  if (!(s.width_m > 0.0 && std::isfinite(s.width_m)))
    fail("strip.width_m", "strip width must be positive, got " + std::to_string(s.width_m));
  if (s.cells_along < 1)
    fail("strip.cells_along", "need at least one cell along, got " + std::to_string(s.cells_along));
  if (s.cells_across < 1)
    fail("strip.cells_across",
         "need at least one cell across, got " + std::to_string(s.cells_across));
  if (!std::isfinite(s.angle_deg)) fail("strip.angle_deg", "material angle must be finite");
}

void validate_parameters(const MaterialParameters& p) {
  auto fail = [](const std::string& key, const std::string& what) {
    throw InputError({"", 0, key}, what);
  };
  if (!(p.thickness_m > 0.0 && std::isfinite(p.thickness_m)))
    fail("thickness_m", "thickness must be positive, got " + std::to_string(p.thickness_m));
  if (!(p.density_kg_m2 >= 0.0 && std::isfinite(p.density_kg_m2)))
    fail("density_kg_m2", "density must be non-negative, got " + std::to_string(p.density_kg_m2));
  // Bending stiffnesses are solved from a11, a22 and a12 + G12 (hinge_bending.hpp); they must
  // describe a sheet that resists bending in every direction.
  if (!(p.a11_Pa > 0.0)) fail("a11_Pa", "a11 must be positive, got " + std::to_string(p.a11_Pa));
  if (!(p.a22_Pa > 0.0)) fail("a22_Pa", "a22 must be positive, got " + std::to_string(p.a22_Pa));
  if (!(p.G12_Pa > 0.0)) fail("G12_Pa", "G12 must be positive, got " + std::to_string(p.G12_Pa));
  const std::array<std::pair<const char*, const Curve*>, 4> curves = {
      {{"eta1", &p.eta1}, {"eta3", &p.eta3}, {"eta4", &p.eta4}, {"eta2", &p.eta2}}};
  for (const auto& [key, c] : curves)
    if (c->degree() < 1 || c->mu.size() != c->alpha.size())
      fail(key, std::string("curve needs as many mu as alpha values, at least one"));
}

Eigen::Vector3d vertex(const Eigen::VectorXd& q, int v) { return q.segment<3>(3 * v); }

/// Derivatives of a hinge term W = k g θ² (kg = k g) over the first N/3 vertices of its angle:
/// all 4 of a hinge, or a clamp hinge's real triangle (its ghost apex is fixed, so only that
/// 9×9 block enters). ∂W/∂x = 2 kg θ ∇θ is added to `gradient`, ∂²W/∂x² = 2 kg (∇θ∇θᵀ + θ∇²θ)
/// through the element's slots to `hessian_values` (each when not null).
template <int N>
void scatter_squared_angle(double kg, double theta, const Vector12& dtheta, const Matrix12& d2theta,
                           std::span<const int> vertices, const int* slots, double* gradient,
                           double* hessian_values) {
  if (gradient) {
    const Eigen::Matrix<double, N, 1> local = 2.0 * kg * theta * dtheta.head<N>();
    scatter_nodal(gradient, vertices, node_major(local));
  }
  if (hessian_values) {
    const Eigen::Matrix<double, N, N> H =
        2.0 * kg *
        (dtheta.head<N>() * dtheta.head<N>().transpose() + theta * d2theta.topLeftCorner<N, N>());
    scatter_hessian(hessian_values, slots, N / 3, node_major_blocks(H));
  }
}

}  // namespace

/// A boundary edge on a clamped end line, hinged against a ghost triangle fixed in the rest
/// plane (triangle_shell.hpp, docs/triangle_shell.md §8). v = (x0, x1, x2) is the real
/// triangle counter-clockwise, local[a] the face-local index of v[a].
struct ClampHinge {
  int face = 0;
  std::array<int, 3> v{}, local{};
  Eigen::Vector3d ghost = Eigen::Vector3d::Zero();  ///< apex of (x1, x0, ghost) at rest
  double weight = 0;                                ///< g_b = |ē|²/(Ā_T/3)
};

struct TriangleShell::Impl {
  explicit Impl(int threads) : runner(threads) {}

  StripTriangulation tri;
  std::vector<ClampHinge> clamp_hinges;
  std::vector<CstReference> cst;     // per face
  std::vector<double> hinge_weight;  // g_e per hinge
  HingeClasses classes;
  std::unique_ptr<HingeCalibration> calibration;
  std::unique_ptr<DirectionalHingeModel> directional;  // hinge_model = directional only
  Eigen::VectorXd vertex_area;  // Σ_{T∋i} Ā_T/3 [m²]

  // hinge_model = shape-operator only (shape_operator_bending.hpp). Angle ids: interior hinges,
  // then clamp hinges. A face's bending stencil is the union of its sources' vertices.
  std::unique_ptr<ShapeOperatorBending> shape;
  ShapeOperatorStiffness shape_stiffness;
  std::vector<std::vector<int>> stencil;  // per face: stencil vertices
  // Per face and source: the stencil slot of each of the angle's vertices (the fourth is −1
  // for a clamp hinge, whose ghost is fixed).
  std::vector<std::vector<std::array<int, 4>>> source_slots;
  std::vector<int> face_source_start;             // per face: start in the flat ∂W/∂φ array
  std::vector<std::vector<int>> angle_users;      // per angle: entries of that array, in order

  // Assembly elements (element_nodes.hpp), ids: triangles [0, #faces), hinges, clamp hinges
  // (their real triangle's 3 vertices), then the shape operator's face stencils. The Hessian
  // pattern holds a full 3×3 block for every vertex pair of an element, with its slot tables.
  ElementNodes elements;
  HessianPattern pattern;
  // Triangles, hinges and clamp hinges by slab of cell columns along x, in a fixed order; the
  // even slabs run in parallel, then the odd ones (element_schedule.hpp: slabs of equal parity
  // share no vertex): two synchronisations per call, no write collisions, and every entry
  // receives its contributions in the same order for any thread count (bitwise-deterministic).
  ElementSchedule schedule;
  // Shape-operator bending assembly, element ids relative to #faces: angles [0, #angles) (the
  // angle ids are the hinges' and clamp hinges' element ids − #faces), then #angles + face
  // (its stencil); slabs as wide as the widest face stencil.
  ElementSchedule bending_schedule;
  int stencil_element(int face) const { return num_elements() + face; }

  // Point location: triangles overlapping each cell.
  std::vector<std::vector<int>> cell_triangles;

  ParallelRunner runner;

  // The constructor's build steps, in the order it runs them.
  void build_reference_elements(double angle_deg);
  void build_clamp_hinges(StripEnds ends, double length_m);
  void build_bending_model(HingeModel model, double angle_deg);
  void build_face_stencils();
  void build_assembly();
  void build_bending_schedule();
  void build_schedule();
  void build_point_location(double width_m);

  int num_faces() const { return tri.num_faces(); }
  int num_angles() const { return shape ? shape->num_angles() : 0; }
  /// Vertices of angle a (shape operator): the hinge's four, or a clamp hinge's three and −1.
  std::array<int, 4> angle_vertices(int a) const {
    if (a < num_hinges()) return tri.hinges[static_cast<size_t>(a)].v;
    const ClampHinge& c = clamp_hinges[static_cast<size_t>(a - num_hinges())];
    return {c.v[0], c.v[1], c.v[2], -1};
  }
  /// θ of angle a with optional gradient/Hessian (12; a clamp hinge's ghost block is unused).
  double angle(const Eigen::VectorXd& q, int a, Vector12* gradient, Matrix12* hessian) const;
  /// θ of every angle (each once: a hinge enters up to ~9 faces), with ∇θ when given.
  void all_angles(const Eigen::VectorXd& q, std::vector<double>* theta,
                  std::vector<Vector12>* dtheta) const {
    const auto na = static_cast<size_t>(num_angles());
    theta->resize(na);
    if (dtheta) dtheta->resize(na);
    for_each_index(num_angles(), [&](int a) {
      const auto u = static_cast<size_t>(a);
      (*theta)[u] = angle(q, a, dtheta ? &(*dtheta)[u] : nullptr, nullptr);
    });
  }
  /// Length of the flat per-(face, source) array indexed by face_source_start.
  size_t num_face_sources() const {
    const auto& faces = shape->faces();
    return faces.empty() ? 0
                         : static_cast<size_t>(face_source_start.back()) + faces.back().sources.size();
  }
  /// Shape-operator bending: W_T of every face into face_energy (#faces); when given, its
  /// gradient is added to `gradient` and its Hessian to `hessian_values` (the pattern's
  /// value array).
  void shape_operator_pass(const Eigen::VectorXd& q, std::vector<double>* face_energy,
                           Eigen::VectorXd* gradient, double* hessian_values) const;
  /// The shape operator's pass, step by step: every face's W_T into face_energy and, with
  /// `derivatives`, ∂W_T/∂φ in the flat per-(face, source) array (returned); an angle's
  /// gradient (w = ∂Ψ/∂θ_a) and Hessian blocks; a face stencil's Hessian block.
  std::vector<double> face_energies(const std::vector<double>& theta, std::vector<double>* face_energy,
                                    bool derivatives) const;
  void scatter_angle(const Eigen::VectorXd& q, int a, double w, const Vector12& dtheta, double* gradient,
                     double* hessian_values) const;
  struct FaceHessianScratch {
    ScratchMatrix Y, SY, H;
  };
  void scatter_face_hessian(int f, const std::vector<Vector12>& dtheta, double* hessian_values,
                            FaceHessianScratch& scratch) const;
  /// Shape-operator bending's columns of ∂(∂Ψ/∂q)/∂p for the bending parameters p, added to B.
  void shape_operator_parameter_columns(const Eigen::VectorXd& q, const MaterialParameters& bending,
                                        Eigen::MatrixXd* B) const;
  int num_hinges() const { return static_cast<int>(tri.hinges.size()); }
  /// Element ids: triangles, then hinges, then clamp hinges.
  int num_elements() const {
    return num_faces() + num_hinges() + static_cast<int>(clamp_hinges.size());
  }

  /// Runs f(element) for every element of `schedule`, conflict-free (see `schedule`).
  template <class F>
  void for_each_scheduled(const ElementSchedule& schedule_, F&& f) const {
    runner.run(schedule_, [&](std::span<const int> ids) {
      for (int id : ids) f(id);
    });
  }

  /// Runs f(i) for i in [0, n), in parallel when worthwhile; f must write only its own slots.
  template <class F>
  void for_each_index(int n, F&& f) const {
    runner.for_each_range(n, kGrain, kParallelMinimum, [&](int begin, int end) {
      for (int i = begin; i < end; ++i) f(i);
    });
  }
};

namespace {

// s_m = E φ of one face (docs §4.7), with φ = −θ over the face's angle sources, in
// `rotations` (#measured); `phi` is scratch.
ScratchMatrix::VectorMap measured_rotations(const ShapeOperatorBending::Face& face,
                                            const std::vector<double>& theta, ScratchMatrix& phi,
                                            ScratchMatrix& rotations) {
  ScratchMatrix::VectorMap p = phi.vector(static_cast<Eigen::Index>(face.sources.size()));
  for (size_t j = 0; j < face.sources.size(); ++j)
    p[static_cast<Eigen::Index>(j)] = -theta[static_cast<size_t>(face.sources[j])];
  ScratchMatrix::VectorMap s = rotations.vector(face.edge_map.rows());
  s.noalias() = face.edge_map * p;
  return s;
}

/// Slabs of cell columns for elements given by their vertex-column range [first, last]: an
/// element belongs to the slab of its first column, and every slab is at least as wide as the
/// widest element's span (and kMinSlabColumns), so slabs of equal parity share no vertex.
std::vector<std::vector<int>> column_slabs(int columns,
                                           const std::vector<std::pair<int, int>>& range) {
  int span = 0;
  for (const auto& [first, last] : range) span = std::max(span, last - first);
  const int num_slabs =
      std::clamp(columns / std::max(kMinSlabColumns, span), 1, kMaxSlabs);
  std::vector<std::vector<int>> out(static_cast<size_t>(num_slabs));
  for (size_t e = 0; e < range.size(); ++e)
    out[static_cast<size_t>(std::min(range[e].first * num_slabs / columns, num_slabs - 1))]
        .push_back(static_cast<int>(e));
  return out;
}

}  // namespace

// The constructor's build steps, in order (each reads what the ones before it built).

void TriangleShell::Impl::build_reference_elements(double angle_deg) {
  const StripTriangulation& t = tri;
  // Material frame (core/discretization.hpp): d2 = (cos θ, sin θ), d1 = (−sin θ, cos θ).
  const double angle = angle_deg * std::numbers::pi / 180.0;
  const Eigen::Vector2d d2(std::cos(angle), std::sin(angle)), d1(-std::sin(angle), std::cos(angle));
  vertex_area = Eigen::VectorXd::Zero(t.num_vertices());
  cst.reserve(static_cast<size_t>(t.num_faces()));
  for (int f = 0; f < t.num_faces(); ++f) {
    const auto X = [&](int k) { return Eigen::Vector2d(t.reference_xy.row(t.faces(f, k))); };
    cst.push_back(cst_reference(X(0), X(1), X(2), d1, d2));
    for (int k = 0; k < 3; ++k) vertex_area[t.faces(f, k)] += cst.back().area / 3.0;
  }
  hinge_weight.reserve(t.hinges.size());
  for (const Hinge& h : t.hinges) hinge_weight.push_back(hinge_reference(t.reference_xy, h).weight);
}

// Clamp hinges: every boundary edge on a selected end line, with the ghost apex the mirror
// image of the real apex across that line (so (x1, x0, ghost) is counter-clockwise and flat).
void TriangleShell::Impl::build_clamp_hinges(StripEnds ends, double length_m) {
  const StripTriangulation& t = tri;
  for (int f = 0; f < t.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      ClampHinge c;
      c.face = f;
      c.local = {k, (k + 1) % 3, (k + 2) % 3};
      for (int a = 0; a < 3; ++a) c.v[a] = t.faces(f, c.local[a]);
      const int hc0 = t.half_column[c.v[0]], hc1 = t.half_column[c.v[1]];
      const bool on_start = hc0 == 0 && hc1 == 0;
      const bool on_end = hc0 == 2 * t.cells_along && hc1 == 2 * t.cells_along;
      if (!((on_start && includes(ends, StripEnd::Start)) || (on_end && includes(ends, StripEnd::End))))
        continue;
      const double line_x = on_start ? 0.0 : length_m;
      const Eigen::Vector2d apex = t.reference_xy.row(c.v[2]);
      c.ghost = Eigen::Vector3d(2.0 * line_x - apex.x(), apex.y(), 0.0);
      const double edge2 = (t.reference_xy.row(c.v[1]) - t.reference_xy.row(c.v[0])).squaredNorm();
      c.weight = edge2 / (cst[static_cast<size_t>(f)].area / 3.0);
      clamp_hinges.push_back(c);
    }
}

void TriangleShell::Impl::build_bending_model(HingeModel model, double angle_deg) {
  classes = classify_hinges(tri);
  calibration = std::make_unique<HingeCalibration>(classes.response, angle_deg);
  if (model == HingeModel::Directional) directional = std::make_unique<DirectionalHingeModel>(tri, classes, angle_deg);
  if (model != HingeModel::ShapeOperator) return;
  std::vector<ClampEdge> clamp_edges;
  for (const ClampHinge& c : clamp_hinges) clamp_edges.push_back({c.face, c.local[0]});
  shape = std::make_unique<ShapeOperatorBending>(tri, clamp_edges, angle_deg);
  build_face_stencils();
}

// Each face's bending stencil (the union of its angle sources' vertices, sorted), the stencil
// slots of every source's vertices, and each angle's entries in the flat ∂W/∂φ array.
void TriangleShell::Impl::build_face_stencils() {
  const auto& faces = shape->faces();
  stencil.resize(faces.size());
  source_slots.resize(faces.size());
  face_source_start.resize(faces.size());
  angle_users.assign(static_cast<size_t>(num_angles()), {});
  int flat = 0;
  for (size_t f = 0; f < faces.size(); ++f) {
    std::vector<int>& st = stencil[f];
    for (int a : faces[f].sources)
      for (int v : angle_vertices(a))
        if (v >= 0 && std::find(st.begin(), st.end(), v) == st.end()) st.push_back(v);
    std::sort(st.begin(), st.end());
    face_source_start[f] = flat;
    for (int a : faces[f].sources) {
      std::array<int, 4> slots{-1, -1, -1, -1};
      const std::array<int, 4> av = angle_vertices(a);
      for (size_t i = 0; i < 4; ++i)
        if (av[i] >= 0) slots[i] = static_cast<int>(std::lower_bound(st.begin(), st.end(), av[i]) - st.begin());
      source_slots[f].push_back(slots);
      angle_users[static_cast<size_t>(a)].push_back(flat++);
    }
  }
}

// Assembly elements and the Hessian pattern: full 3×3 blocks for every vertex pair of a
// triangle, a hinge or a face's bending stencil (a clamp hinge's lie in its triangle's); then
// the slab schedules.
void TriangleShell::Impl::build_assembly() {
  const StripTriangulation& t = tri;
  for (int f = 0; f < t.num_faces(); ++f) elements.add(std::array<int, 3>{t.faces(f, 0), t.faces(f, 1), t.faces(f, 2)});
  for (const Hinge& h : t.hinges) elements.add(h.v);
  for (const ClampHinge& c : clamp_hinges) elements.add(c.v);
  for (const std::vector<int>& st : stencil) elements.add(st);
  pattern = HessianPattern(t.num_vertices(), elements);
  if (shape) build_bending_schedule();
  build_schedule();
}

// Bending assembly elements: angles (a hinge spans ≤ 2 columns), then faces (stencils up to 5
// columns on the regular patterns); slabs as wide as the widest.
void TriangleShell::Impl::build_bending_schedule() {
  std::vector<std::pair<int, int>> range;
  auto columns_of = [&](const auto& vertices) {
    std::pair<int, int> r{tri.cells_along, 0};
    for (int v : vertices)
      if (v >= 0) {
        const int c = tri.half_column[static_cast<size_t>(v)] / 2;
        r.first = std::min(r.first, c);
        r.second = std::max(r.second, c);
      }
    return r;
  };
  for (int a = 0; a < num_angles(); ++a) range.push_back(columns_of(angle_vertices(a)));
  for (const std::vector<int>& st : stencil) range.push_back(columns_of(st));
  bending_schedule = ElementSchedule::alternating(column_slabs(tri.cells_along, range));
}

// Slabs: an element belongs to the slab of its leftmost vertex column.
void TriangleShell::Impl::build_schedule() {
  const StripTriangulation& t = tri;
  const int columns = t.cells_along;
  const int num_slabs = std::clamp(columns / kMinSlabColumns, 1, kMaxSlabs);
  std::vector<std::vector<int>> slabs(static_cast<size_t>(num_slabs));
  auto slab_of = [&](const auto& vertices) {
    int column = columns;
    for (int v : vertices) column = std::min(column, t.half_column[static_cast<size_t>(v)] / 2);
    return static_cast<size_t>(std::min(column * num_slabs / columns, num_slabs - 1));
  };
  for (int f = 0; f < t.num_faces(); ++f)
    slabs[slab_of(std::array<int, 3>{t.faces(f, 0), t.faces(f, 1), t.faces(f, 2)})].push_back(f);
  for (int h = 0; h < num_hinges(); ++h) slabs[slab_of(t.hinges[static_cast<size_t>(h)].v)].push_back(t.num_faces() + h);
  for (size_t c = 0; c < clamp_hinges.size(); ++c)
    slabs[slab_of(clamp_hinges[c].v)].push_back(t.num_faces() + num_hinges() + static_cast<int>(c));
  schedule = ElementSchedule::alternating(slabs);
}

// Point location grid (cells of the unperturbed pattern; perturbed triangles overlap at most
// the neighbouring cells, found through their bounding boxes).
void TriangleShell::Impl::build_point_location(double width_m) {
  const StripTriangulation& t = tri;
  const int nx = t.cells_along, ny = t.cells_across;
  cell_triangles.assign(static_cast<size_t>(nx * ny), {});
  const double y0 = -0.5 * width_m;
  const auto cell_index = [](double value, double h, int n) {
    return std::clamp(static_cast<int>(std::floor(value / h)), 0, n - 1);
  };
  // Widen by a little so points on shared edges find both triangles.
  const double ex = kPointLocationSlack * t.cell_length_m, ey = kPointLocationSlack * t.cell_width_m;
  for (int f = 0; f < t.num_faces(); ++f) {
    Eigen::Vector2d lo = t.reference_xy.row(t.faces(f, 0)), hi = lo;
    for (int k = 1; k < 3; ++k) {
      lo = lo.cwiseMin(Eigen::Vector2d(t.reference_xy.row(t.faces(f, k))));
      hi = hi.cwiseMax(Eigen::Vector2d(t.reference_xy.row(t.faces(f, k))));
    }
    const int i0 = cell_index(lo.x() - ex, t.cell_length_m, nx);
    const int i1 = cell_index(hi.x() + ex, t.cell_length_m, nx);
    const int j0 = cell_index(lo.y() - y0 - ey, t.cell_width_m, ny);
    const int j1 = cell_index(hi.y() - y0 + ey, t.cell_width_m, ny);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) cell_triangles[static_cast<size_t>(j * nx + i)].push_back(f);
  }
}

TriangleShell::TriangleShell(const StripSpec& strip, const MaterialParameters& parameters,
                             const TriangleShellOptions& options)
    : strip_(strip), options_(options) {
  validate_strip(strip);
  require_valid(options, "triangle-shell");
  validate_parameters(parameters);

  impl_ = std::make_unique<Impl>(options.threads);
  Impl& m = *impl_;
  m.tri = triangulate_strip(strip, options.pattern, options.perturbation, options.seed);
  rest_ = Eigen::VectorXd::Zero(3 * m.tri.num_vertices());
  for (int v = 0; v < m.tri.num_vertices(); ++v) rest_.segment<2>(3 * v) = m.tri.reference_xy.row(v).transpose();
  m.build_reference_elements(strip.angle_deg);
  m.build_clamp_hinges(options.clamp_hinges, strip.length_m);
  m.build_bending_model(options.hinge_model, strip.angle_deg);
  m.build_assembly();
  m.build_point_location(strip.width_m);

  law_ = std::make_unique<MaterialLaw>(parameters);
  update_hinge_stiffness();
}

void TriangleShell::update_hinge_stiffness() {
  Impl& m = *impl_;
  bending_ = bending_parameters(*law_, &bending_chain_);
  const MaterialParameters& p = bending_;
  try {
    if (m.shape) {
      m.shape_stiffness = m.shape->solve(p);
      // No hinge energies; the shape operator is exact for the four calibration cylinders in
      // the continuum limit (relative_error = 0).
      stiffness_ = HingeClassStiffness{};
      hinges_ = HingeStiffness{};
      hinges_.per_hinge = Eigen::VectorXd::Zero(m.num_hinges());
      hinges_.derivative = Eigen::Matrix<double, Eigen::Dynamic, 5>::Zero(m.num_hinges(), 5);
      return;
    }
    if (m.directional) {
      stiffness_ = HingeClassStiffness{};
      hinges_ = m.directional->solve(p);
      return;
    }
    stiffness_ = m.calibration->solve(p);
  } catch (const std::invalid_argument& e) {
    throw InputError({"", 0, "a12_Pa"}, e.what());
  }
  const auto nh = static_cast<Eigen::Index>(m.classes.class_of_hinge.size());
  hinges_ = HingeStiffness{};
  hinges_.per_hinge.resize(nh);
  hinges_.derivative.resize(nh, 5);
  for (Eigen::Index h = 0; h < nh; ++h) {
    const int c = m.classes.class_of_hinge[static_cast<size_t>(h)];
    hinges_.per_hinge[h] = stiffness_.stiffness[c];
    hinges_.derivative.row(h) = stiffness_.derivative.row(c);
  }
  hinges_.relative_error = stiffness_.relative_error;
}

TriangleShell::~TriangleShell() = default;

int TriangleShell::num_nodes() const { return impl_->tri.num_vertices(); }
const StripTriangulation& TriangleShell::triangulation() const { return impl_->tri; }
const std::vector<int>& TriangleShell::hinge_class() const { return impl_->classes.class_of_hinge; }
const HingeCalibration& TriangleShell::hinge_calibration() const { return *impl_->calibration; }
const DirectionalHingeModel* TriangleShell::directional_model() const {
  return impl_->directional.get();
}
const ShapeOperatorBending* TriangleShell::shape_operator() const { return impl_->shape.get(); }
const ShapeOperatorStiffness& TriangleShell::shape_operator_stiffness() const {
  return impl_->shape_stiffness;
}

void TriangleShell::set_parameters(const MaterialParameters& parameters) {
  validate_parameters(parameters);
  law_ = std::make_unique<MaterialLaw>(parameters);
  update_hinge_stiffness();
}

double TriangleShell::energy(const Eigen::VectorXd& q, Eigen::VectorXd* gradient,
                             SparseMatrix* hessian) const {
  const Impl& m = *impl_;
  assert(q.size() == num_dofs());
  const double tau = law_->parameters().thickness_m;
  const double rho = law_->parameters().density_kg_m2;
  const int nf = m.num_faces();
  const int nh = m.num_hinges();
  const double clamp_k = clamp_hinge_stiffness();
  std::vector<double> element_energy(static_cast<size_t>(m.num_elements()), 0.0);

  if (gradient) gradient->setZero(num_dofs());
  double* const values = hessian ? m.pattern.prepare(hessian) : nullptr;
  double* const g = gradient ? gradient->data() : nullptr;

  auto element = [&](int id) {
    if (id < nf) {
      const std::span<const int> v = m.elements[id];
      Vector9 local_gradient;
      Matrix9 H;
      element_energy[static_cast<size_t>(id)] =
          cst_energy(*law_, tau, m.cst[static_cast<size_t>(id)], vertex(q, v[0]), vertex(q, v[1]),
                     vertex(q, v[2]), gradient ? &local_gradient : nullptr, hessian ? &H : nullptr);
      if (gradient) scatter_nodal(g, v, node_major(local_gradient));
      if (hessian) scatter_hessian(values, m.pattern.slots(id), 3, node_major_blocks(H));
      return;
    }
    if (m.shape) return;  // bending: shape_operator_pass below
    // Hinge, or clamp hinge (angle id = element id − #faces): W = k g θ².
    const int a = id - nf;
    const double kg = a < nh ? hinges_.per_hinge[a] * m.hinge_weight[static_cast<size_t>(a)]
                             : clamp_k * m.clamp_hinges[static_cast<size_t>(a - nh)].weight;
    Vector12 dtheta;
    Matrix12 d2theta;
    const double theta = m.angle(q, a, (gradient || hessian) ? &dtheta : nullptr,
                                 hessian ? &d2theta : nullptr);
    element_energy[static_cast<size_t>(id)] = kg * theta * theta;
    const std::span<const int> v = m.elements[id];
    if (v.size() == 4)
      scatter_squared_angle<12>(kg, theta, dtheta, d2theta, v, m.pattern.slots(id), g, values);
    else
      scatter_squared_angle<9>(kg, theta, dtheta, d2theta, v, m.pattern.slots(id), g, values);
  };

  if (gradient || hessian) {
    m.for_each_scheduled(m.schedule, element);
  } else {
    // Energy only: each element writes its own slot, any split is safe.
    m.runner.for_each_range(static_cast<int>(element_energy.size()), kGrain, 4 * kParallelMinimum,
                            [&](int begin, int end) {
                              for (int id = begin; id < end; ++id) element(id);
                            });
  }

  std::vector<double> face_energy;
  if (m.shape) m.shape_operator_pass(q, &face_energy, gradient, values);

  // Summed in element order: the same value for every thread count.
  double total = 0.0;
  for (double e : element_energy) total += e;
  for (double e : face_energy) total += e;
  return subtract_gravity(m.vertex_area, rho, gravity_, q, total, gradient);
}

TriangleShellEnergyParts TriangleShell::energy_parts(const Eigen::VectorXd& q) const {
  const Impl& m = *impl_;
  const StripTriangulation& t = m.tri;
  TriangleShellEnergyParts parts;
  const double tau = law_->parameters().thickness_m;
  for (int f = 0; f < m.num_faces(); ++f)
    parts.membrane +=
        cst_energy(*law_, tau, m.cst[static_cast<size_t>(f)], vertex(q, t.faces(f, 0)),
                   vertex(q, t.faces(f, 1)), vertex(q, t.faces(f, 2)));
  parts.bending =
      hinge_energies(q).sum() + clamp_hinge_energies(q).sum() + face_bending_energies(q).sum();
  for (int v = 0; v < t.num_vertices(); ++v)
    parts.gravity -=
        law_->parameters().density_kg_m2 * m.vertex_area[v] * gravity_.dot(vertex(q, v));
  return parts;
}

Eigen::VectorXd TriangleShell::hinge_energies(const Eigen::VectorXd& q) const {
  const Impl& m = *impl_;
  const StripTriangulation& t = m.tri;
  Eigen::VectorXd out(m.num_hinges());
  for (size_t h = 0; h < t.hinges.size(); ++h) {
    const auto& v = t.hinges[h].v;
    const double theta =
        dihedral_angle(vertex(q, v[0]), vertex(q, v[1]), vertex(q, v[2]), vertex(q, v[3]));
    out[static_cast<Eigen::Index>(h)] =
        hinges_.per_hinge[static_cast<Eigen::Index>(h)] * m.hinge_weight[h] * theta * theta;
  }
  return out;
}

Eigen::VectorXd TriangleShell::clamp_hinge_energies(const Eigen::VectorXd& q) const {
  const Impl& m = *impl_;
  if (m.shape) return Eigen::VectorXd::Zero(static_cast<Eigen::Index>(m.clamp_hinges.size()));
  const double k = clamp_hinge_stiffness();
  Eigen::VectorXd out(static_cast<Eigen::Index>(m.clamp_hinges.size()));
  for (size_t i = 0; i < m.clamp_hinges.size(); ++i) {
    const ClampHinge& c = m.clamp_hinges[i];
    const double theta =
        dihedral_angle(vertex(q, c.v[0]), vertex(q, c.v[1]), vertex(q, c.v[2]), c.ghost);
    out[static_cast<Eigen::Index>(i)] = k * c.weight * theta * theta;
  }
  return out;
}

Eigen::VectorXd TriangleShell::face_bending_energies(const Eigen::VectorXd& q) const {
  const Impl& m = *impl_;
  if (!m.shape) return Eigen::VectorXd::Zero(m.num_faces());
  std::vector<double> energy;
  m.shape_operator_pass(q, &energy, nullptr, nullptr);
  return Eigen::Map<const Eigen::VectorXd>(energy.data(), static_cast<Eigen::Index>(energy.size()));
}

Eigen::Matrix<double, Eigen::Dynamic, 3> TriangleShell::face_curvatures(
    const Eigen::VectorXd& q) const {
  const Impl& m = *impl_;
  if (!m.shape)
    throw std::logic_error("face_curvatures: only the shape-operator bending model has them");
  Eigen::VectorXd phi(m.num_angles());
  for (int a = 0; a < m.num_angles(); ++a) phi[a] = -m.angle(q, a, nullptr, nullptr);
  return m.shape->curvatures(phi, m.shape_stiffness);
}

double TriangleShell::Impl::angle(const Eigen::VectorXd& q, int a, Vector12* gradient,
                                  Matrix12* hessian) const {
  if (a < num_hinges()) {
    const auto& v = tri.hinges[static_cast<size_t>(a)].v;
    return dihedral_angle(vertex(q, v[0]), vertex(q, v[1]), vertex(q, v[2]), vertex(q, v[3]),
                          gradient, hessian);
  }
  const ClampHinge& c = clamp_hinges[static_cast<size_t>(a - num_hinges())];
  return dihedral_angle(vertex(q, c.v[0]), vertex(q, c.v[1]), vertex(q, c.v[2]), c.ghost,
                        gradient, hessian);
}

void TriangleShell::Impl::shape_operator_pass(const Eigen::VectorXd& q,
                                              std::vector<double>* face_energy,
                                              Eigen::VectorXd* gradient,
                                              double* hessian_values) const {
  const bool derivatives = gradient || hessian_values;
  // 1. Every angle once: θ and ∇θ (the faces use them). ∇²θ is computed in step 4 where it is
  //    used, once per angle: storing it for every angle cost 1152 bytes an angle per call.
  std::vector<double> theta;
  std::vector<Vector12> dtheta;
  all_angles(q, &theta, derivatives ? &dtheta : nullptr);
  // 2. Faces: W_T and ∂W_T/∂φ.
  const std::vector<double> dW = face_energies(theta, face_energy, derivatives);
  if (!derivatives) return;
  // 3. ∂Ψ/∂φ_a, summed over the angle's faces in a fixed order.
  std::vector<double> lambda(static_cast<size_t>(num_angles()), 0.0);
  for_each_index(num_angles(), [&](int a) {
    double sum = 0.0;
    for (int i : angle_users[static_cast<size_t>(a)]) sum += dW[static_cast<size_t>(i)];
    lambda[static_cast<size_t>(a)] = sum;
  });
  // 4. Assembly. Gradient Σ_a λ_a ∂φ_a/∂q; Hessian Σ_a λ_a ∂²φ_a/∂q² (on the hinge's blocks)
  //    + Σ_T 2 (E ∂φ/∂q)ᵀ S (E ∂φ/∂q) (on the face stencil's blocks). A range of elements
  //    reuses one set of scratch matrices.
  runner.run(bending_schedule, [&](std::span<const int> ids) {
    FaceHessianScratch scratch;
    for (const int id : ids) {
      if (id < num_angles())
        scatter_angle(q, id, -lambda[static_cast<size_t>(id)], dtheta[static_cast<size_t>(id)],
                      gradient ? gradient->data() : nullptr, hessian_values);
      else if (hessian_values)
        scatter_face_hessian(id - num_angles(), dtheta, hessian_values, scratch);
    }
  });
}

std::vector<double> TriangleShell::Impl::face_energies(const std::vector<double>& theta,
                                                       std::vector<double>* face_energy, bool derivatives) const {
  // s_m = E φ, W_T = s_mᵀ S s_m, ∂W_T/∂φ = 2 Eᵀ S s_m (φ = −θ), the last into the flat array.
  const auto& faces = shape->faces();
  const int nf = static_cast<int>(faces.size());
  face_energy->assign(static_cast<size_t>(nf), 0.0);
  std::vector<double> dW(derivatives ? num_face_sources() : 0, 0.0);
  runner.for_each_range(nf, kGrain, kParallelMinimum, [&](int begin, int end) {
    ScratchMatrix phi, rotations_storage, Ss_storage, d_storage;  // reused by the range's faces
    for (int f = begin; f < end; ++f) {
      const auto fu = static_cast<size_t>(f);
      const ShapeOperatorBending::Face& face = faces[fu];
      if (face.measured.empty()) continue;
      const auto rotations = measured_rotations(face, theta, phi, rotations_storage);
      auto Ss = Ss_storage.vector(rotations.size());
      Ss.noalias() = shape_stiffness.form[fu] * rotations;
      (*face_energy)[fu] = rotations.dot(Ss);
      if (!derivatives) continue;
      auto d = d_storage.vector(static_cast<Eigen::Index>(face.sources.size()));
      d.noalias() = 2.0 * face.edge_map.transpose() * Ss;
      for (size_t j = 0; j < face.sources.size(); ++j)
        dW[static_cast<size_t>(face_source_start[fu]) + j] = d[static_cast<Eigen::Index>(j)];
    }
  });
  return dW;
}

void TriangleShell::Impl::scatter_angle(const Eigen::VectorXd& q, int a, double w, const Vector12& dtheta,
                                        double* gradient, double* hessian_values) const {
  // w = ∂Ψ/∂θ_a = −λ_a (∂φ/∂q = −∂θ/∂q).
  const int element = num_faces() + a;  // pattern element of angle a (element ids above)
  const std::span<const int> v = elements[element];  // 4, or a clamp hinge's 3
  if (gradient) scatter_nodal(gradient, v, [&](int i, int c) { return w * dtheta[3 * i + c]; });
  if (!hessian_values) return;
  Vector12 unused;
  Matrix12 d2theta;
  angle(q, a, &unused, &d2theta);
  scatter_hessian(hessian_values, pattern.slots(element), static_cast<int>(v.size()),
                  [&](int i, int r, int j, int c) { return w * d2theta(3 * i + r, 3 * j + c); });
}

void TriangleShell::Impl::scatter_face_hessian(int f, const std::vector<Vector12>& dtheta, double* hessian_values,
                                               FaceHessianScratch& scratch) const {
  const auto fu = static_cast<size_t>(f);
  const ShapeOperatorBending::Face& face = shape->faces()[fu];
  if (face.measured.empty()) return;
  // Y = E ∂φ/∂q on the face's stencil; its Hessian 2 Yᵀ S Y.
  const auto n = static_cast<Eigen::Index>(stencil[fu].size());
  auto Y = scratch.Y(static_cast<Eigen::Index>(face.measured.size()), 3 * n);
  Y.setZero();
  for (size_t j = 0; j < face.sources.size(); ++j) {
    const auto a = static_cast<size_t>(face.sources[j]);
    const std::array<int, 4>& slots = source_slots[fu][j];
    for (int i = 0; i < 4; ++i)
      if (slots[static_cast<size_t>(i)] >= 0)
        Y.middleCols<3>(3 * slots[static_cast<size_t>(i)]).noalias() -=
            face.edge_map.col(static_cast<Eigen::Index>(j)) * dtheta[a].segment<3>(3 * i).transpose();
  }
  auto SY = scratch.SY(Y.rows(), Y.cols());
  SY.noalias() = shape_stiffness.form[fu] * Y;
  auto H = scratch.H(3 * n, 3 * n);
  H.noalias() = 2.0 * Y.transpose() * SY;
  scatter_hessian(hessian_values, pattern.slots(stencil_element(f)), static_cast<int>(n), node_major_blocks(H));
}

void TriangleShell::Impl::shape_operator_parameter_columns(const Eigen::VectorXd& q, const MaterialParameters& bending,
                                                           Eigen::MatrixXd* B) const {
  // ∂(∂Ψ/∂q)/∂p = Σ_a (∂λ_a/∂p) ∂φ_a/∂q with ∂λ_a/∂p = Σ_T 2 (Eᵀ ∂S_T/∂p s_m)_a
  // (shape_operator_bending.hpp (4): ∂S/∂p = Tᵀ ∂Q/∂p T).
  const int na = num_angles();
  const auto& faces = shape->faces();
  std::vector<double> theta;
  std::vector<Vector12> dtheta;
  all_angles(q, &theta, &dtheta);
  std::vector<Eigen::Matrix<double, 1, 5>> dW(num_face_sources(), Eigen::Matrix<double, 1, 5>::Zero());
  runner.for_each_range(static_cast<int>(faces.size()), kGrain, kParallelMinimum, [&](int begin, int end) {
    ScratchMatrix phi, rotations_storage, dSs_storage, d_storage;  // reused by the range
    for (int f = begin; f < end; ++f) {
      const auto fu = static_cast<size_t>(f);
      const ShapeOperatorBending::Face& face = faces[fu];
      if (face.measured.empty()) continue;
      const auto rotations = measured_rotations(face, theta, phi, rotations_storage);
      const auto dS = shape->form_derivative(f, bending, shape_stiffness);
      for (size_t p = 0; p < dS.size(); ++p) {
        auto dSs = dSs_storage.vector(dS[p].rows());
        dSs.noalias() = dS[p] * rotations;
        auto d = d_storage.vector(face.edge_map.cols());
        d.noalias() = 2.0 * face.edge_map.transpose() * dSs;
        for (size_t j = 0; j < face.sources.size(); ++j)
          dW[static_cast<size_t>(face_source_start[fu]) + j][static_cast<Eigen::Index>(p)] =
              d[static_cast<Eigen::Index>(j)];
      }
    }
  });
  for_each_scheduled(bending_schedule, [&](int id) {
    if (id >= na) return;
    Eigen::Matrix<double, 1, 5> lambda = Eigen::Matrix<double, 1, 5>::Zero();
    for (int i : angle_users[static_cast<size_t>(id)]) lambda += dW[static_cast<size_t>(i)];
    const Vector12& dtheta_a = dtheta[static_cast<size_t>(id)];
    for (Eigen::Index p = 0; p < kBendingParameters; ++p) {
      const double l = lambda[p];
      // −λ ∂θ/∂q added: the same bits as λ ∂θ/∂q subtracted.
      scatter_nodal(B->col(p).data(), elements[num_faces() + id],
                    [&](int i, int r) { return -(l * dtheta_a[3 * i + r]); });
    }
  });
}

double TriangleShell::clamp_hinge_stiffness(Eigen::Matrix<double, 1, 5>* derivative) const {
  // k_b = W_cyl(x̂)/3: the cylinder z = κx²/2 across the end line tilts a clamp-hinge
  // triangle with apex at distance a from the line by θ = κa/2, and the hinge should carry
  // the KL energy of the half of that triangle's strip next to the line, W_cyl κ² Ā_T
  // (docs/triangle_shell.md §8); with g_b = 3|ē|²/Ā_T and Ā_T = |ē| a/2 this is W_cyl/3 for
  // every apex position. ũ = (x̂·d1, x̂·d2) = (−sin θ_m, cos θ_m) (core/discretization.hpp).
  const double angle = strip_.angle_deg * std::numbers::pi / 180.0;
  const double u1 = -std::sin(angle), u2 = std::cos(angle);
  const double w = kirchhoff_love_cylinder_energy(bending_,
                                                  Eigen::Vector3d(u1 * u1, u2 * u2, u1 * u2),
                                                  derivative);
  if (derivative) *derivative /= 3.0;
  return w / 3.0;
}

void TriangleShell::gradient_parameter_jacobian(const Eigen::VectorXd& q,
                                                Eigen::MatrixXd* dgradient_dk) const {
  const Impl& m = *impl_;
  const int nk = law_->num_parameters();
  const double tau = law_->parameters().thickness_m;
  const int nf = m.num_faces();
  Eigen::MatrixXd& J = *dgradient_dk;
  J.setZero(num_dofs(), nk);
  // Bending terms by the bending models' parameters (a11', a12', a22', G12', τ), chained to the
  // flat vector at the end (bending_parameters()).
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(num_dofs(), kBendingParameters);
  const int nh = m.num_hinges();
  Eigen::Matrix<double, 1, 5> clamp_dk;
  clamp_hinge_stiffness(&clamp_dk);
  m.for_each_scheduled(m.schedule, [&](int id) {
    if (id >= nf && m.shape) return;  // shape-operator bending below
    const std::span<const int> v = m.elements[id];
    if (id >= nf + nh) {
      // ∂(2 k_b g θ ∇θ)/∂p = 2 (∂k_b/∂p) g θ ∇θ, over the real triangle's vertices.
      const ClampHinge& c = m.clamp_hinges[static_cast<size_t>(id - nf - nh)];
      Vector12 dtheta;
      const double theta = dihedral_angle(vertex(q, c.v[0]), vertex(q, c.v[1]),
                                          vertex(q, c.v[2]), c.ghost, &dtheta, nullptr);
      for (Eigen::Index p = 0; p < kBendingParameters; ++p) {
        const double scale = 2.0 * clamp_dk[p] * c.weight * theta;
        scatter_nodal(B.col(p).data(), v,
                      [&](int a, int r) { return scale * dtheta[3 * a + r]; });
      }
      return;
    }
    if (id < nf) {
      const Eigen::Matrix<double, 9, Eigen::Dynamic> local =
          cst_gradient_parameter_jacobian(*law_, tau, m.cst[static_cast<size_t>(id)],
                                          vertex(q, v[0]), vertex(q, v[1]), vertex(q, v[2]));
      for (Eigen::Index col = 0; col < local.cols(); ++col)
        scatter_nodal(J.col(col).data(), v, [&](int a, int r) { return local(3 * a + r, col); });
      return;
    }
    const auto hu = static_cast<size_t>(id - nf);
    Vector12 dtheta;
    const double theta = dihedral_angle(vertex(q, v[0]), vertex(q, v[1]), vertex(q, v[2]),
                                        vertex(q, v[3]), &dtheta, nullptr);
    // ∂(2 k g θ ∇θ)/∂k_param = 2 (∂k/∂param) g θ ∇θ.
    const Vector12 unit = 2.0 * m.hinge_weight[hu] * theta * dtheta;
    const auto he = static_cast<Eigen::Index>(hu);
    for (Eigen::Index p = 0; p < kBendingParameters; ++p) {
      const double dk = hinges_.derivative(he, p);
      if (dk == 0.0) continue;
      scatter_nodal(B.col(p).data(), v,
                    [&](int a, int r) { return dk * unit[3 * a + r]; });
    }
  });
  if (m.shape) m.shape_operator_parameter_columns(q, bending_, &B);
  J.noalias() += B * bending_chain_;
  // Gravity: ∂(−m_i g)/∂ρ_A = −(Σ Ā_T/3) g.
  subtract_gravity_density_column(m.vertex_area, gravity_, FlatLayout::kDensity, dgradient_dk);
}

std::vector<int> TriangleShell::clamped_nodes(StripEnd end, bool clamp_slope) const {
  const StripTriangulation& t = impl_->tri;
  const int last = 2 * t.cells_along;
  std::vector<int> out;
  for (int v = 0; v < t.num_vertices(); ++v) {
    const int hc = t.half_column[static_cast<size_t>(v)];
    const int from_end = end == StripEnd::Start ? hc : last - hc;
    // With clamp hinges on this end the hinges hold the slope; otherwise the next vertex
    // column (and the cross pattern's centres between) is held too (triangle_shell.hpp).
    const bool hinged = includes(options_.clamp_hinges, end);
    if (from_end == 0 || (clamp_slope && !hinged && from_end <= 2)) out.push_back(v);
  }
  return out;
}

SparseMatrix TriangleShell::point_evaluation(const std::vector<Eigen::Vector2d>& points) const {
  const Impl& m = *impl_;
  const StripTriangulation& t = m.tri;
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(points.size() * 9);
  const double y0 = -0.5 * strip_.width_m;
  // A point counts as inside the strip up to this relative slack (round-off in callers).
  const double slack = 1e-9;
  for (size_t p = 0; p < points.size(); ++p) {
    const Eigen::Vector2d& x = points[p];
    const double u = x.x() / t.cell_length_m, w = (x.y() - y0) / t.cell_width_m;
    if (!(u >= -slack && u <= t.cells_along + slack && w >= -slack && w <= t.cells_across + slack))
      throw InputError({"", 0, "points[" + std::to_string(p) + "]"},
                       "point (" + std::to_string(x.x()) + ", " + std::to_string(x.y()) +
                           ") m is outside the strip");
    const int i = std::clamp(static_cast<int>(std::floor(u)), 0, t.cells_along - 1);
    const int j = std::clamp(static_cast<int>(std::floor(w)), 0, t.cells_across - 1);
    int best = -1;
    double best_min = -std::numeric_limits<double>::infinity();
    Eigen::Vector3d best_lambda;
    for (int f : m.cell_triangles[static_cast<size_t>(j * t.cells_along + i)]) {
      const Eigen::Vector2d a = t.reference_xy.row(t.faces(f, 0));
      const Eigen::Vector2d b = t.reference_xy.row(t.faces(f, 1));
      const Eigen::Vector2d c = t.reference_xy.row(t.faces(f, 2));
      Eigen::Matrix2d T;
      T.col(0) = b - a;
      T.col(1) = c - a;
      const Eigen::Vector2d l12 = T.inverse() * (x - a);
      const Eigen::Vector3d lambda(1.0 - l12.sum(), l12.x(), l12.y());
      if (lambda.minCoeff() > best_min) {
        best_min = lambda.minCoeff();
        best = f;
        best_lambda = lambda;
      }
    }
    if (best < 0 || best_min < -1e-6)
      throw InputError({"", 0, "points[" + std::to_string(p) + "]"},
                       "no triangle contains point (" + std::to_string(x.x()) + ", " +
                           std::to_string(x.y()) + ") m");
    for (int k = 0; k < 3; ++k)
      for (int r = 0; r < 3; ++r)
        triplets.emplace_back(static_cast<int>(3 * p) + r, 3 * t.faces(best, k) + r,
                              best_lambda[k]);
  }
  SparseMatrix P(static_cast<Eigen::Index>(3 * points.size()), num_dofs());
  P.setFromTriplets(triplets.begin(), triplets.end());
  return P;
}

Eigen::VectorXd TriangleShell::lumped_mass() const {
  const Impl& m = *impl_;
  return twill::lumped_mass(m.vertex_area, law_->parameters().density_kg_m2);
}

void TriangleShell::surface_mesh(const Eigen::VectorXd& q, Eigen::MatrixXd* vertices,
                                 Eigen::MatrixXi* faces) const {
  if (vertices) {
    vertices->resize(num_nodes(), 3);
    for (int v = 0; v < num_nodes(); ++v) vertices->row(v) = vertex(q, v).transpose();
  }
  if (faces) *faces = impl_->tri.faces;
}

}  // namespace twill
