#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "core/input_error.hpp"
#include "discretizations/assembly/block_scatter.hpp"
#include "discretizations/assembly/element_nodes.hpp"
#include "discretizations/assembly/element_schedule.hpp"
#include "discretizations/assembly/hessian_pattern.hpp"
#include "discretizations/assembly/nodal_gravity.hpp"
#include "discretizations/assembly/parallel_runner.hpp"
#include "discretizations/catmull_clark_kl/kirchhoff_love_face.hpp"
#include "discretizations/catmull_clark_kl/kirchhoff_love_kernel.hpp"

namespace twill {
namespace {

using BasisTable = Eigen::Matrix<double, 6, 16>;  // rows as PatchBasis::weights

void validate_strip(const StripSpec& strip) {
  auto fail = [](const char* key, const std::string& message) {
    throw InputError(InputLocation{"", 0, key}, message);
  };
  if (!(std::isfinite(strip.length_m) && strip.length_m > 0))
    fail("length_m", "strip length must be positive, got " + std::to_string(strip.length_m));
  if (!(std::isfinite(strip.width_m) && strip.width_m > 0))
    fail("width_m", "strip width must be positive, got " + std::to_string(strip.width_m));
  if (strip.cells_along < 1)
    fail("cells_along", "needs at least 1 cell, got " + std::to_string(strip.cells_along));
  if (strip.cells_across < 1)
    fail("cells_across", "needs at least 1 cell, got " + std::to_string(strip.cells_across));
  if (!std::isfinite(strip.angle_deg)) fail("angle_deg", "material angle must be finite");
}

void validate_parameters(const MaterialParameters& p) {
  if (!(std::isfinite(p.thickness_m) && p.thickness_m > 0))
    throw InputError(InputLocation{"", 0, "thickness_m"},
                     "thickness must be positive, got " + std::to_string(p.thickness_m));
  if (!std::isfinite(p.density_kg_m2))
    throw InputError(InputLocation{"", 0, "density_kg_m2"}, "density must be finite");
}

/// Surface jet of a basis table's point: the face kernel's own function (see face_jet).
SurfaceJet jet_of(const BasisTable& table, const FaceCoordinates& X) {
  return face_jet(table.bottomRows<5>().transpose(), X);
}

/// The face's 16 control points at q (row k: node k).
FaceCoordinates face_coordinates(const Eigen::VectorXd& q, std::span<const int> nodes) {
  FaceCoordinates X;
  for (int k = 0; k < 16; ++k) X.row(k) = q.segment<3>(3 * nodes[static_cast<size_t>(k)]).transpose();
  return X;
}

}  // namespace

OptionBindings<CatmullClarkKLOptions> catmull_clark_kl_option_bindings() {
  using O = CatmullClarkKLOptions;
  std::vector<std::pair<std::string, FibreStrain>> fibre_strains;
  for (const auto& [value, name] : fibre_strain_names()) fibre_strains.emplace_back(name, value);
  return {
      integer_option<O>("gauss_points_per_direction", &O::gauss_points_per_direction,
                        "Gauss points per face direction (paper §6.3: 4x4)", in_range(1, 16)),
      // One point (the mid-surface) would drop the bending energy entirely.
      integer_option<O>("thickness_points", &O::thickness_points,
                        "Gauss-Legendre points through the thickness (one point loses all bending)",
                        in_range(2, 64)),
      integer_option<O>("threads", &O::threads, "assembly threads; 0 = TBB's choice", in_range(0, 256)),
      integer_option<O>("surface_samples_per_face", &O::surface_samples_per_face,
                        "limit-surface samples per face edge for OBJ output", in_range(1, 64)),
      enum_option<O>("fibre_strain", &O::fibre_strain, fibre_strains,
                     "fibre stretches per Gauss point (paper) or L2-projected per face onto "
                     "constants / linears / bilinears (B-bar against locking; docs/catmull_clark_kl.md 12)"),
  };
}

bool CatmullClarkKLOptions::validate(std::string* error) const {
  if (!check_options(catmull_clark_kl_option_bindings(), *this, error)) return false;
  // The linear modes of a projection need two points per direction to have a norm.
  if (projection_modes(fibre_strain) > 1 && gauss_points_per_direction < 2) {
    if (error)
      *error = "gauss_points_per_direction must be >= 2 for fibre_strain=" +
               std::string(fibre_strain_name(fibre_strain)) + ", got " +
               std::to_string(gauss_points_per_direction);
    return false;
  }
  return true;
}

struct CatmullClarkKL::Mesh {
  explicit Mesh(int threads) : runner(threads) {}

  int points_per_face = 0;
  std::vector<Eigen::Vector2d> gauss_uv;        // per point of a face
  std::vector<BasisTable> basis_tables;         // [table · points_per_face + point]
  std::vector<JetBasis> jet_basis;              // Dᵀ of basis_tables, contiguous, same index
  std::vector<int> face_table;                  // per face
  ElementNodes face_nodes;                      // per face: its 16 control points
  std::vector<ReferencePoint> reference;        // [face · points_per_face + point]
  /// Reference (x, y) = c0 + u c1 + v c2 on each face (its affine parametrisation).
  std::vector<Eigen::Matrix<double, 2, 3>> face_affine;
  Eigen::VectorXd node_area;  // ∫ N_i dA per node [m²]
  HessianPattern pattern;     // both triangles; element = face (slot tables 16·16·3)
  ElementSchedule colours;    // greedy colouring: faces of one colour share no node
  ParallelRunner runner;

  // The constructor's build steps, in the order it runs them.
  std::vector<double> set_gauss_rule(int points_per_direction);
  int shared_table(const std::vector<BasisTable>& tables);
  void add_face(const LimitSurfaceBasis& basis, int face, const Eigen::VectorXd& rest,
                const std::vector<double>& gauss_weight, const Eigen::Vector3d& d1, const Eigen::Vector3d& d2);
  void finish(int num_nodes);

  std::size_t bytes() const {
    std::size_t total = gauss_uv.capacity() * sizeof(Eigen::Vector2d) +
                        basis_tables.capacity() * sizeof(BasisTable) +
                        jet_basis.capacity() * sizeof(JetBasis) +
                        face_table.capacity() * sizeof(int) + face_nodes.bytes() +
                        reference.capacity() * sizeof(ReferencePoint) +
                        face_affine.capacity() * sizeof(Eigen::Matrix<double, 2, 3>) +
                        static_cast<std::size_t>(node_area.size()) * sizeof(double) +
                        pattern.bytes() + colours.bytes();
    return total;
  }
};

// The tensor Gauss rule on a face's (u, v) ∈ [0, 1]²: the points into gauss_uv, their weights
// (summing to 1) returned.
std::vector<double> CatmullClarkKL::Mesh::set_gauss_rule(int points_per_direction) {
  const GaussLegendreRule face_rule = GaussLegendreRule::make(points_per_direction);
  const int ng = face_rule.size();
  points_per_face = ng * ng;
  std::vector<double> gauss_weight;
  for (int b = 0; b < ng; ++b)
    for (int a = 0; a < ng; ++a) {
      gauss_uv.emplace_back(0.5 * (1.0 + face_rule.nodes[static_cast<size_t>(a)]),
                            0.5 * (1.0 + face_rule.nodes[static_cast<size_t>(b)]));
      gauss_weight.push_back(0.25 * face_rule.weights[static_cast<size_t>(a)] *
                             face_rule.weights[static_cast<size_t>(b)]);
    }
  return gauss_weight;
}

// The index of a face's basis tables (one per Gauss point) in basis_tables, added when new:
// faces of the same boundary type have bitwise identical tables, stored once.
int CatmullClarkKL::Mesh::shared_table(const std::vector<BasisTable>& tables) {
  const auto npf = static_cast<size_t>(points_per_face);
  for (std::size_t t = 0; t * npf < basis_tables.size(); ++t) {
    bool same = true;
    for (size_t p = 0; p < npf && same; ++p) same = basis_tables[t * npf + p] == tables[p];
    if (same) return static_cast<int>(t);
  }
  basis_tables.insert(basis_tables.end(), tables.begin(), tables.end());
  return static_cast<int>(basis_tables.size() / npf) - 1;
}

// One face: its control points, basis tables, reference points (and their share of each
// node's area) and affine parametrisation.
void CatmullClarkKL::Mesh::add_face(const LimitSurfaceBasis& surface, int face, const Eigen::VectorXd& rest,
                                    const std::vector<double>& gauss_weight, const Eigen::Vector3d& d1,
                                    const Eigen::Vector3d& d2) {
  const int npf = points_per_face;
  std::vector<BasisTable> tables(static_cast<size_t>(npf));
  PatchBasis basis;
  for (int p = 0; p < npf; ++p) {
    basis = surface.evaluate(face, gauss_uv[static_cast<size_t>(p)].x(), gauss_uv[static_cast<size_t>(p)].y());
    tables[static_cast<size_t>(p)] = basis.weights;
  }
  face_nodes.add(basis.nodes);
  face_table[static_cast<size_t>(face)] = shared_table(tables);

  FaceCoordinates X;
  for (int k = 0; k < 16; ++k) X.row(k) = rest.segment<3>(3 * basis.nodes[static_cast<size_t>(k)]).transpose();
  for (int p = 0; p < npf; ++p) {
    const BasisTable& W = tables[static_cast<size_t>(p)];
    ReferencePoint& ref = reference[static_cast<size_t>(face * npf + p)];
    ref = make_reference_point(jet_of(W, X), gauss_weight[static_cast<size_t>(p)], d1, d2);
    for (int k = 0; k < 16; ++k) node_area[basis.nodes[static_cast<size_t>(k)]] += ref.weight_area * W(0, k);
  }
  Eigen::Matrix<double, 2, 3>& affine = face_affine[static_cast<size_t>(face)];
  const Eigen::Vector3d origin = (surface.evaluate(face, 0, 0).weights.row(0) * X).transpose();
  affine.col(0) = origin.head<2>();
  affine.col(1) = (surface.evaluate(face, 1, 0).weights.row(0) * X).transpose().head<2>() - origin.head<2>();
  affine.col(2) = (surface.evaluate(face, 0, 1).weights.row(0) * X).transpose().head<2>() - origin.head<2>();
}

// The jet bases, and the Hessian pattern: nodes i, j are coupled when some face's patch uses
// both; the colouring of faces that share no node.
void CatmullClarkKL::Mesh::finish(int num_nodes) {
  for (const BasisTable& table : basis_tables) jet_basis.emplace_back(table.bottomRows<5>().transpose());
  pattern = HessianPattern(num_nodes, face_nodes);
  colours = ElementSchedule::colouring(face_nodes, num_nodes);
}

CatmullClarkKL::CatmullClarkKL(const StripSpec& strip, const MaterialParameters& parameters,
                               const CatmullClarkKLOptions& options)
    : strip_(strip), options_(options), law_(parameters) {
  validate_strip(strip);
  validate_parameters(parameters);
  require_valid(options, "catmull-clark-kl");
  thickness_rule_ = GaussLegendreRule::make(options.thickness_points);
  basis_ = std::make_unique<LimitSurfaceBasis>(strip.cells_along, strip.cells_across);

  const int nx = strip.cells_along, ny = strip.cells_across;
  rest_.resize(3 * basis_->num_nodes());
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i)
      rest_.segment<3>(3 * basis_->node_index(i, j)) << strip.length_m * i / nx,
          -0.5 * strip.width_m + strip.width_m * j / ny, 0.0;

  // Material frame (core/discretization.hpp): d2 = weft at θ from the strip axis, d1 = warp.
  const double theta = strip.angle_deg * std::numbers::pi / 180.0;
  const Eigen::Vector3d d2(std::cos(theta), std::sin(theta), 0.0);
  const Eigen::Vector3d d1(-std::sin(theta), std::cos(theta), 0.0);

  auto mesh = std::make_unique<Mesh>(options.threads);
  const std::vector<double> gauss_weight = mesh->set_gauss_rule(options.gauss_points_per_direction);
  const auto num_faces = static_cast<size_t>(basis_->num_faces());
  mesh->face_table.resize(num_faces);
  mesh->reference.resize(num_faces * static_cast<size_t>(mesh->points_per_face));
  mesh->face_affine.resize(num_faces);
  mesh->node_area = Eigen::VectorXd::Zero(basis_->num_nodes());
  for (int face = 0; face < basis_->num_faces(); ++face) mesh->add_face(*basis_, face, rest_, gauss_weight, d1, d2);
  mesh->finish(basis_->num_nodes());
  mesh_ = std::move(mesh);
}

CatmullClarkKL::~CatmullClarkKL() = default;

void CatmullClarkKL::set_parameters(const MaterialParameters& parameters) {
  validate_parameters(parameters);
  law_ = MaterialLaw(parameters);
}

int CatmullClarkKL::num_quadrature_points() const {
  return num_faces() * mesh_->points_per_face;
}

std::size_t CatmullClarkKL::precomputation_bytes() const { return mesh_->bytes(); }

FaceQuadrature CatmullClarkKL::face_quadrature(int face) const {
  const Mesh& mesh = *mesh_;
  const int npf = mesh.points_per_face;
  FaceQuadrature quadrature;
  quadrature.points_per_face = npf;
  quadrature.jet_basis =
      mesh.jet_basis.data() + static_cast<std::size_t>(mesh.face_table[static_cast<size_t>(face)] * npf);
  quadrature.reference = mesh.reference.data() + static_cast<std::size_t>(face * npf);
  quadrature.gauss_uv = mesh.gauss_uv.data();
  quadrature.fibre_strain = options_.fibre_strain;
  return quadrature;
}

void CatmullClarkKL::check_positions(const Eigen::VectorXd& q, const char* caller) const {
  if (q.size() != num_dofs())
    throw std::invalid_argument(std::string("CatmullClarkKL::") + caller + ": q has " +
                                std::to_string(q.size()) + " entries, the mesh has " +
                                std::to_string(num_dofs()) + " dofs");
}

double CatmullClarkKL::energy(const Eigen::VectorXd& q, Eigen::VectorXd* gradient,
                              SparseMatrix* hessian) const {
  check_positions(q, "energy");
  const Mesh& mesh = *mesh_;
  const int n = num_dofs();
  if (gradient) gradient->setZero(n);
  double* const values = hessian ? mesh.pattern.prepare(hessian) : nullptr;

  std::vector<double> face_energy(static_cast<size_t>(num_faces()), 0.0);
  const double tau = law_.parameters().thickness_m;
  // One face into `g` and `H` (the gradient and Hessian values, or private copies of them).
  auto add_face = [&](int face, double* g, double* H) {
    const std::span<const int> nodes = mesh.face_nodes[face];
    FaceCoordinates face_gradient;
    FaceHessianBlocks blocks;  // (a, b) component blocks, a ≤ b, of the 48×48 Hessian
    face_energy[static_cast<size_t>(face)] =
        kirchhoff_love_face(law_, tau, thickness_rule_, face_quadrature(face),
                            face_coordinates(q, nodes), g ? &face_gradient : nullptr,
                            H ? &blocks : nullptr);
    if (g) scatter_nodal(g, nodes, [&](int k, int c) { return face_gradient(k, c); });
    // Entry (3 i + a, 3 j + b) of the local Hessian is block (a, b) at (i, j), or the
    // transpose of block (b, a) below the diagonal.
    if (H)
      scatter_hessian(H, mesh.pattern.slots(face), 16, [&](int i, int a, int j, int b) {
        return a <= b ? blocks[static_cast<size_t>(face_block_index(a, b))](i, j)
                      : blocks[static_cast<size_t>(face_block_index(b, a))](j, i);
      });
  };
  double* const g = gradient ? gradient->data() : nullptr;
  if (options_.assembly == CatmullClarkKLOptions::Assembly::Colouring) {
    mesh.runner.run(mesh.colours, [&](std::span<const int> faces) {
      for (int face : faces) add_face(face, g, values);
    });
  } else {
    std::vector<std::pair<double*, std::size_t>> targets;
    if (g) targets.emplace_back(g, static_cast<std::size_t>(n));
    if (values) targets.emplace_back(values, mesh.pattern.num_nonzeros());
    mesh.runner.run_with_private_copies(num_faces(), targets, [&](int begin, int end, double* const* outputs) {
      for (int face = begin; face < end; ++face) add_face(face, g ? outputs[0] : nullptr, values ? outputs[g ? 1 : 0] : nullptr);
    });
  }

  double total = 0.0;
  for (double e : face_energy) total += e;  // serial sum: deterministic
  return subtract_gravity(mesh.node_area, law_.parameters().density_kg_m2, gravity_, q, total,
                          gradient);
}

void CatmullClarkKL::gradient_parameter_jacobian(const Eigen::VectorXd& q,
                                                 Eigen::MatrixXd* dgradient_dk) const {
  check_positions(q, "gradient_parameter_jacobian");
  if (!dgradient_dk) throw std::invalid_argument("gradient_parameter_jacobian: null output");
  const Mesh& mesh = *mesh_;
  const int n = num_dofs();
  const int num_k = law_.num_parameters();
  dgradient_dk->setZero(n, num_k);
  const double tau = law_.parameters().thickness_m;

  // Faces of a range share one 48 × num_parameters scratch (rows 16 c + k: node k, comp c).
  auto add_faces = [&](int begin, int end, const int* faces, double* out) {
    FaceParameterJacobian local;
    for (int i = begin; i < end; ++i) {
      const int face = faces ? faces[i] : i;
      const std::span<const int> nodes = mesh.face_nodes[face];
      kirchhoff_love_face_parameter_jacobian(law_, tau, thickness_rule_, face_quadrature(face),
                                             face_coordinates(q, nodes), &local);
      for (int col = 0; col < num_k; ++col)
        scatter_nodal(out + static_cast<std::size_t>(col) * static_cast<std::size_t>(n), nodes,
                      [&](int k, int c) { return local(16 * c + k, col); });
    }
  };
  if (options_.assembly == CatmullClarkKLOptions::Assembly::Colouring) {
    mesh.runner.run(mesh.colours, [&](std::span<const int> faces) {
      add_faces(0, static_cast<int>(faces.size()), faces.data(), dgradient_dk->data());
    });
  } else {
    const std::vector<std::pair<double*, std::size_t>> targets = {
        {dgradient_dk->data(), static_cast<std::size_t>(n) * static_cast<std::size_t>(num_k)}};
    mesh.runner.run_with_private_copies(num_faces(), targets, [&](int begin, int end, double* const* outputs) {
      add_faces(begin, end, nullptr, outputs[0]);
    });
  }
  // Density enters through gravity only: ∂g_i/∂ρ_A = −(∫N_i dA) g.
  subtract_gravity_density_column(mesh.node_area, gravity_, FlatLayout::kDensity, dgradient_dk);
}

std::vector<int> CatmullClarkKL::clamped_nodes(StripEnd end, bool clamp_slope) const {
  const int nx = strip_.cells_along, ny = strip_.cells_across;
  std::vector<int> rows = {end == StripEnd::Start ? 0 : nx};
  if (clamp_slope) rows.push_back(end == StripEnd::Start ? std::min(1, nx) : std::max(nx - 1, 0));
  std::vector<int> nodes;
  for (int i : rows)
    for (int j = 0; j <= ny; ++j) nodes.push_back(basis_->node_index(i, j));
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return nodes;
}

SparseMatrix CatmullClarkKL::point_evaluation(const std::vector<Eigen::Vector2d>& points) const {
  const int nx = strip_.cells_along, ny = strip_.cells_across;
  const double L = strip_.length_m, Wd = strip_.width_m;
  const double tolerance = 1e-9 * std::max(L, Wd);
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(points.size() * 48);
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Eigen::Vector2d& point = points[k];
    if (!(point.x() >= -tolerance && point.x() <= L + tolerance &&
          std::abs(point.y()) <= 0.5 * Wd + tolerance)) {
      std::ostringstream message;
      message << "point (" << point.x() << ", " << point.y() << ") m is outside the strip [0, "
              << L << "] x [" << -0.5 * Wd << ", " << 0.5 * Wd << "]";
      throw InputError(InputLocation{"", 0, "points[" + std::to_string(k) + "]"}, message.str());
    }
    const int i = std::clamp(static_cast<int>(std::floor(point.x() / L * nx)), 0, nx - 1);
    const int j = std::clamp(static_cast<int>(std::floor((point.y() + 0.5 * Wd) / Wd * ny)), 0, ny - 1);
    const int face = basis_->face_index(i, j);
    const Eigen::Matrix<double, 2, 3>& affine = mesh_->face_affine[static_cast<size_t>(face)];
    const Eigen::Vector2d uv =
        affine.rightCols<2>().partialPivLu().solve(point - affine.col(0)).cwiseMax(0.0).cwiseMin(1.0);
    const PatchBasis basis = basis_->evaluate(face, uv.x(), uv.y());
    for (int m = 0; m < 16; ++m)
      for (int c = 0; c < 3; ++c)
        triplets.emplace_back(static_cast<int>(3 * k) + c, 3 * basis.nodes[static_cast<size_t>(m)] + c,
                              basis.weights(0, m));
  }
  SparseMatrix P(3 * static_cast<Eigen::Index>(points.size()), num_dofs());
  P.setFromTriplets(triplets.begin(), triplets.end());
  P.prune(0.0);  // phantom slots of boundary patches carry exact zeros
  return P;
}

Eigen::VectorXd CatmullClarkKL::lumped_mass() const {
  return twill::lumped_mass(mesh_->node_area, law_.parameters().density_kg_m2);
}

void CatmullClarkKL::surface_mesh(const Eigen::VectorXd& q, Eigen::MatrixXd* vertices,
                                  Eigen::MatrixXi* faces) const {
  check_positions(q, "surface_mesh");
  const int s = options_.surface_samples_per_face;
  const int cols = strip_.cells_along * s, rows = strip_.cells_across * s;
  std::vector<Eigen::Vector2d> samples;
  samples.reserve(static_cast<size_t>((cols + 1) * (rows + 1)));
  for (int b = 0; b <= rows; ++b)
    for (int a = 0; a <= cols; ++a)
      samples.emplace_back(strip_.length_m * a / cols,
                           -0.5 * strip_.width_m + strip_.width_m * b / rows);
  if (vertices) {
    const Eigen::VectorXd positions = point_evaluation(samples) * q;
    *vertices = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(
        positions.data(), static_cast<Eigen::Index>(samples.size()), 3);
  }
  if (faces) {
    faces->resize(2 * cols * rows, 3);
    int t = 0;
    for (int b = 0; b < rows; ++b)
      for (int a = 0; a < cols; ++a) {
        const int v00 = b * (cols + 1) + a, v10 = v00 + 1, v01 = v00 + cols + 1, v11 = v01 + 1;
        faces->row(t++) << v00, v10, v11;
        faces->row(t++) << v00, v11, v01;
      }
  }
}

std::vector<CatmullClarkKL::PointStrain> CatmullClarkKL::quadrature_strains(
    const Eigen::VectorXd& q) const {
  check_positions(q, "quadrature_strains");
  const Mesh& mesh = *mesh_;
  const int npf = mesh.points_per_face;
  std::vector<PointStrain> strains;
  strains.reserve(static_cast<size_t>(num_quadrature_points()));
  for (int face = 0; face < num_faces(); ++face) {
    const FaceCoordinates X = face_coordinates(q, mesh.face_nodes[face]);
    const Eigen::Matrix<double, 2, 3>& affine = mesh.face_affine[static_cast<size_t>(face)];
    std::array<Vector6, 256> e;  // points_per_face ≤ 16² (validated)
    kirchhoff_love_face_strains(face_quadrature(face), X, e.data());
    for (int p = 0; p < npf; ++p) {
      PointStrain point;
      point.reference_point = affine.col(0) + affine.rightCols<2>() * mesh.gauss_uv[static_cast<size_t>(p)];
      point.membrane = e[static_cast<size_t>(p)].head<3>();
      point.bending = e[static_cast<size_t>(p)].tail<3>();
      strains.push_back(point);
    }
  }
  return strains;
}

}  // namespace twill
