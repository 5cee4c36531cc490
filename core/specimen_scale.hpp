#pragma once
// Specimen scales: the repeat scatter of a tensile test modelled as one factor per run
// (`repeats.scale: per-run`; docs/fitting.md §3a, docs/discover-design.md §1).
//
// Repeats of one test differ by 10–20 % in force (paper §6.4, §7): width, yarn count and cut
// vary between specimens. With every repeat fitted (`repeats.rule=all`) the curve then lands
// between them and an effect fitted per run (offsets, rates) absorbs the scatter instead of its
// own physics. The model here: run r's prediction is s_r p̂_r(k), s_r > 0, and the scales of
// the runs of one test (a "group") keep their geometric mean at 1,
//
//     Σ_{r ∈ g} log s_r = 0,
//
// so the fitted stiffness is the geometric-mean specimen's (without the gauge a common factor
// of the group's scales trades exactly with the test's stiffness for any curve linear in it).
// Profiled out of Eq. 3: with q_r = p̂_r / p̆_r (elementwise), w_r the run's weight,
//
//     f_r(s) = w_r Σ_i (s q_ri − 1)²,   min Σ_r f_r(s_r)  s.t.  Σ_r log s_r = 0.
//
// Stationarity in u_r = log s_r: s_r f_r'(s_r) = λ for every run of the group, i.e.
// 2 w_r (A_r s² − B_r s) = λ with A_r = Σ q², B_r = Σ q, whose positive root s_r(λ) rises with
// λ; λ is the root of Σ_r log s_r(λ) = 0 (bisection: monotone, no derivatives needed, ~60
// evaluations of a closed form per group). A group of one run keeps s = 1.
//
// Derivatives: at the constrained optimum ∂f/∂u_r = λ for all r and Σ du_r = 0, so the
// envelope theorem gives the profiled objective's gradient as ∂/∂k at fixed scales:
// ∇ε = 2 J_sᵀ r with J_s = diag(√w s_r / p̆) ∂p̂/∂k. The Jacobian handed to the optimisers is
// Kaufman's variable-projection Jacobian (L. Kaufman, BIT 15, 1975; Golub & Pereyra, Inverse
// Problems 19, 2003, §3): J = (I − P) J_s, P the orthogonal projection onto the residual
// directions the scales can take, the columns S_r = √w s_r q_r (on run r's rows) minus their
// group's mean (Σ du_r = 0). Its gradient is the same (the stationarity of the scales is
// Pᵀr = 0 up to the profiling's round-off); Gauss–Newton's model JᵀJ then no longer counts on
// decreases the scales have already taken (the derivative of the profiled residual, dropping
// terms proportional to the residual). Measured: docs/fitting.md §3b.
#include <Eigen/Core>
#include <vector>

namespace twill {

/// One run of a scale group: its predictions over its measurements q = p̂ / p̆, and its weight.
struct ScaledRun {
  const Eigen::VectorXd* relative_prediction = nullptr;
  double weight = 1;
};

/// The profiled scales of one group (above): one per run, Π s = 1. Returns all ones when the
/// group has one run, or when some run's predictions do not point the measured way (Σ q ≤ 0:
/// no positive scale fits it).
std::vector<double> profiled_group_scales(const std::vector<ScaledRun>& group);

}  // namespace twill
