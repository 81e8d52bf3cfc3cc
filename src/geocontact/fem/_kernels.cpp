// geocontact.fem._kernels: the finite-strain element kernels of fem/finite_strain.py compiled
// (issue 36). One call per Newton iterate evaluates, element by element and point by point, what
// FiniteStrainSolver._evaluate computes with numpy over (elements, points) arrays: the
// kinematics with F-bar, the Hencky/exponential-map update with the Drucker-Prager return
// mapping of fem/plasticity.py and its consistent tangent, the internal force and the element
// matrices. The equations, their derivation and references are those of the two Python modules'
// docstrings; this file follows them line by line, in the same order, so that the two agree to
// round-off (tests/test_fem_kernels.py). `scatter` adds element matrices into a fixed sparse
// pattern through a precomputed map (fem/compiled.py builds it).
//
// Layouts (C order): gradients of the reference shape functions (elements, points, 5, 12) with
// the 5-vector components [rr, zz, tt, rz, zr] (rz = d/dz of the r component); point fields
// (4, elements, points) as the engine's State; element matrices (elements, 12, 12).
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace nb = nanobind;
using namespace nb::literals;

#ifndef GEOCONTACT_KERNELS_HASH
#define GEOCONTACT_KERNELS_HASH "unknown"  // built without CMakeLists.txt
#endif

namespace {

constexpr int LOCAL = 12;   // dofs of a P2 vector triangle
constexpr int COMPS = 5;    // gradient components
constexpr int MAX_POINTS = 16;
constexpr int RR = 0, ZZ = 1, TT = 2, RZ = 3, ZR = 4;
constexpr int IN_PLANE[2][2] = {{RR, RZ}, {ZR, ZZ}};  // component of d(.)_i / dx_k
constexpr double SQRT2 = 1.41421356237309504880;
constexpr double SQRT6 = 2.44948974278317809820;
constexpr double IDENTITY[4] = {1.0, 1.0, 1.0, 0.0};
constexpr double STRESS_TO_MANDEL[4] = {1.0, 1.0, 1.0, SQRT2};
constexpr double STRAIN_TO_MANDEL[4] = {1.0, 1.0, 1.0, 1.0 / SQRT2};
constexpr signed char ELASTIC = 0, CONE = 1, APEX = 2;

template <class T, int N>
using Array = nb::ndarray<T, nb::ndim<N>, nb::c_contig, nb::device::cpu>;

// Material constants of the return mapping (plasticity.DruckerPrager), SI units.
struct DruckerPrager {
  double shear, bulk, tan_beta, yield_stress, hardening;
  double cohesion_factor() const { return 1.0 - tan_beta / 3.0; }
  double compressive_yield_stress(double eqps) const { return yield_stress + hardening * eqps; }
};

double deviatoric(int i, int j) { return (i == j ? 1.0 : 0.0) - IDENTITY[i] * IDENTITY[j] / 3.0; }

// 4x4 isotropic elasticity, stress from engineering strain (DruckerPrager.elastic_matrix).
void elastic_matrix(const DruckerPrager &m, double d[4][4])
{
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      d[i][j] = (2.0 * m.shear * deviatoric(i, j) + m.bulk * IDENTITY[i] * IDENTITY[j]) *
                STRAIN_TO_MANDEL[i] * STRAIN_TO_MANDEL[j];
}

// Backward-Euler return to the cone or apex (plasticity.return_mapping, de Souza Neto et al.
// 2008, Box 8.9): stress and eqps out, the consistent tangent (engineering) if `tangent`.
signed char return_mapping(const DruckerPrager &m, const double trial[4], double eqps_old,
                           double stress[4], double &eqps, double tangent[4][4])
{
  const double G = m.shear, K = m.bulk, tb = m.tan_beta, H = m.hardening;
  const double c = m.cohesion_factor();
  double dev[4];
  const double mean = (trial[0] + trial[1] + trial[2]) / 3.0;  // Mandel = engineering here
  double norm2 = 0.0;
  for (int i = 0; i < 4; ++i) {
    dev[i] = trial[i] * STRESS_TO_MANDEL[i] - IDENTITY[i] * mean;
    norm2 += dev[i] * dev[i];
  }
  const double norm = std::sqrt(norm2);
  const double p_tr = -mean, q_tr = std::sqrt(1.5) * norm;
  const double scale = c * m.compressive_yield_stress(eqps_old);
  const double f_tr = q_tr - p_tr * tb - scale;
  const bool plastic = f_tr > 1e-12 * scale;
  const double a_cone = 3.0 * G + K * tb * tb + c * c * H;
  double dlam = plastic ? f_tr / a_cone : 0.0;
  const bool apex = plastic && (q_tr - 3.0 * G * dlam < 0.0) && tb > 0.0;
  const bool cone = plastic && !apex;
  double shrink = 1.0, p_new = p_tr;
  eqps = eqps_old;
  if (cone) {
    shrink = 1.0 - 3.0 * G * dlam / (norm > 0.0 ? q_tr : 1.0);
    p_new = p_tr + K * tb * dlam;
    eqps = eqps_old + c * dlam;
  }
  const double a_apex = apex ? K * tb + c * c * H / tb : 0.0;
  if (apex) {
    const double dvol = (-tb * p_tr - c * m.compressive_yield_stress(eqps_old)) / a_apex;
    p_new = p_tr + K * dvol;
    shrink = 0.0;
    eqps = eqps_old + (c / tb) * dvol;
  }
  for (int i = 0; i < 4; ++i)
    stress[i] = (dev[i] * shrink - IDENTITY[i] * p_new) / STRESS_TO_MANDEL[i];
  if (tangent != nullptr) {
    double n[4] = {0.0, 0.0, 0.0, 0.0}, b[4] = {0.0, 0.0, 0.0, 0.0}, ratio = 0.0;
    if (cone) {
      ratio = 3.0 * G * dlam / q_tr;
      for (int i = 0; i < 4; ++i) {
        n[i] = dev[i] / norm;
        b[i] = SQRT6 * G * n[i] + K * tb * IDENTITY[i];
      }
    }
    const double k_apex = apex ? K * (1.0 - K * tb / a_apex) : 0.0;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const double ii = IDENTITY[i] * IDENTITY[j];
        double t;
        if (cone)
          t = 2.0 * G * (1.0 - ratio) * deviatoric(i, j) + 2.0 * G * ratio * n[i] * n[j] +
              K * ii - b[i] * b[j] / a_cone;
        else if (apex)
          t = k_apex * ii;
        else
          t = 2.0 * G * deviatoric(i, j) + K * ii;
        tangent[i][j] = t * STRAIN_TO_MANDEL[i] * STRAIN_TO_MANDEL[j];
      }
  }
  return apex ? APEX : (cone ? CONE : ELASTIC);
}

// Eigenvalues (ascending) and eigenvectors (columns) of a symmetric 2x2 [[a, c], [c, d]]: the
// eigenvectors of finite_strain._eig, (-sin t, cos t) and (cos t, sin t) with
// t = atan2(c, (a - d) / 2) / 2, from the half-angle formulas instead of atan2, cos and sin
// (the same vectors to round-off; each root taken where it does not cancel).
struct Eigen2 {
  double value[2];
  double vector[2][2];
};

Eigen2 eigen2(double a, double c, double d)
{
  const double half = 0.5 * (a - d);
  const double radius = std::hypot(half, c), mean = 0.5 * (a + d);
  double cos = 1.0, sin = 0.0;  // radius 0: atan2(0, 0) = 0
  if (radius > 0.0) {
    if (half >= 0.0) {
      cos = std::sqrt(0.5 * (1.0 + half / radius));
      sin = c / (2.0 * radius * cos);
    } else {  // t near +-pi/2, with the sign of c (atan2(-0, x < 0) = -pi)
      sin = std::copysign(std::sqrt(0.5 * (1.0 - half / radius)), c);
      cos = c / (2.0 * radius * sin);
    }
  }
  Eigen2 e;
  e.value[0] = mean - radius;
  e.value[1] = mean + radius;
  e.vector[0][0] = -sin;
  e.vector[1][0] = cos;
  e.vector[0][1] = cos;
  e.vector[1][1] = sin;
  return e;
}

void inverse2(const double m[2][2], double inv[2][2])
{
  const double det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
  inv[0][0] = m[1][1] / det;
  inv[1][1] = m[0][0] / det;
  inv[0][1] = -m[0][1] / det;
  inv[1][0] = -m[1][0] / det;
}

// The constitutive update at one point (finite_strain.FiniteUpdate): from H_bar = F_bar - I and
// the plastic metric cp = C_p^-1 - I of the last converged state, the Kirchhoff stress, the new
// cp, eqps, status, the logarithmic plastic strain increment and, if `a_mat` is not null, the
// material tangent contracted to the 5x5 of tau : g (SYM^T d tau / d h).
struct PointResult {
  double stress[4], cp[4], plastic_strain[4], eqps;
  signed char status;
};

void point_update(const DruckerPrager &m, const double d_el[4][4], const double h[5],
                  const double cp_old[4], double eqps_old, bool plastic, PointResult &out,
                  double (*a_mat)[COMPS])
{
  const double hm[2][2] = {{h[RR], h[RZ]}, {h[ZR], h[ZZ]}};
  const double ht = h[TT];
  const double gm[2][2] = {{cp_old[0], cp_old[3]}, {cp_old[3], cp_old[1]}};
  const double gt = cp_old[2];
  // b - I = (G - I) + H G + G H^T + H G H^T, G = I + cp: carried as a difference from I
  double hg[2][2], b_minus[2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      hg[i][j] = hm[i][0] * ((j == 0 ? 1.0 : 0.0) + gm[0][j]) +
                 hm[i][1] * ((j == 1 ? 1.0 : 0.0) + gm[1][j]);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      b_minus[i][j] = gm[i][j] + hg[i][j] + hg[j][i] + (hg[i][0] * hm[j][0] + hg[i][1] * hm[j][1]);
  const double bt_minus = gt + ht * (2.0 + ht) * (1.0 + gt);
  const Eigen2 b = eigen2(b_minus[0][0], 0.5 * (b_minus[0][1] + b_minus[1][0]), b_minus[1][1]);
  const double (&vec)[2][2] = b.vector;
  const double log_half[2] = {0.5 * std::log1p(b.value[0]), 0.5 * std::log1p(b.value[1])};
  double eps[2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      eps[i][j] = vec[i][0] * log_half[0] * vec[j][0] + vec[i][1] * log_half[1] * vec[j][1];
  const double trial_strain[4] = {eps[0][0], eps[1][1], 0.5 * std::log1p(bt_minus),
                                  2.0 * (0.5 * (eps[0][1] + eps[1][0]))};  // engineering shear
  double trial[4];
  for (int i = 0; i < 4; ++i)
    trial[i] = d_el[i][0] * trial_strain[0] + d_el[i][1] * trial_strain[1] +
               d_el[i][2] * trial_strain[2] + d_el[i][3] * trial_strain[3];
  double d_ep[4][4];
  if (plastic) {
    out.status = return_mapping(m, trial, eqps_old, out.stress, out.eqps,
                                a_mat != nullptr ? d_ep : nullptr);
  } else {
    for (int i = 0; i < 4; ++i) {
      out.stress[i] = trial[i];
      for (int j = 0; j < 4; ++j)
        d_ep[i][j] = d_el[i][j];
    }
    out.eqps = eqps_old;
    out.status = ELASTIC;
  }
  // elastic strain C^-1 : tau (plasticity.elastic_strain)
  const double *s = out.stress;
  const double mean = (s[0] + s[1] + s[2]) / 3.0;
  double elastic[4];
  for (int i = 0; i < 4; ++i)
    elastic[i] = (s[i] - IDENTITY[i] * mean) / (2.0 * m.shear) +
                 IDENTITY[i] * (mean / (3.0 * m.bulk));
  elastic[3] *= 2.0;
  for (int i = 0; i < 4; ++i)
    out.plastic_strain[i] = trial_strain[i] - elastic[i];
  // exponential map: b_e = exp(2 eps_e), C_p^-1 = F^-1 b_e F^-T; with K = F^-1 - I:
  // C_p^-1 - I = K + K^T + K K^T + F^-1 (b_e - I) F^-T
  const Eigen2 e = eigen2(elastic[0], 0.5 * (0.5 * elastic[3] + 0.5 * elastic[3]), elastic[1]);
  const double grow[2] = {std::expm1(2.0 * e.value[0]), std::expm1(2.0 * e.value[1])};
  double be_minus[2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      be_minus[i][j] = e.vector[i][0] * grow[0] * e.vector[j][0] +
                       e.vector[i][1] * grow[1] * e.vector[j][1];
  const double f[2][2] = {{1.0 + hm[0][0], hm[0][1]}, {hm[1][0], 1.0 + hm[1][1]}};
  double finv[2][2], k[2][2], fb[2][2], cp[2][2];
  inverse2(f, finv);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      k[i][j] = -(hm[i][0] * finv[0][j] + hm[i][1] * finv[1][j]);
      fb[i][j] = finv[i][0] * be_minus[0][j] + finv[i][1] * be_minus[1][j];
    }
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      cp[i][j] = k[i][j] + k[j][i] + (k[i][0] * k[j][0] + k[i][1] * k[j][1]) +
                 (fb[i][0] * finv[j][0] + fb[i][1] * finv[j][1]);
  out.cp[0] = cp[0][0];
  out.cp[1] = cp[1][1];
  out.cp[2] = std::expm1(2.0 * elastic[2] - 2.0 * std::log1p(ht));  // exp(2 e_tt) / F_tt^2 - 1
  out.cp[3] = 0.5 * (cp[0][1] + cp[1][0]);
  if (a_mat == nullptr)
    return;

  // d tau / d h (FiniteUpdate.material_tangent): d b = h b + b h^T, d eps = d ln(b) / 2 in the
  // eigenbasis of b with the weights of ln, then D^ep.
  const double lam[2] = {1.0 + b.value[0], 1.0 + b.value[1]};
  double w_log[2][2];
  {
    const double diff = lam[0] - lam[1];
    const bool close = std::fabs(diff) < 1e-8 * std::fabs(lam[0]);
    const double off = close ? 1.0 / (0.5 * (lam[0] + lam[1]))
                             : (std::log(lam[0]) - std::log(lam[1])) / diff;
    w_log[0][0] = 1.0 / lam[0];
    w_log[1][1] = 1.0 / lam[1];
    w_log[0][1] = w_log[1][0] = off;
  }
  double d_strain[4][COMPS] = {};
  for (int i = 0; i < 2; ++i)
    for (int mm = 0; mm < 2; ++mm) {
      const int col = IN_PLANE[i][mm];
      const double v[2] = {vec[i][0], vec[i][1]};
      const double w[2] = {lam[0] * vec[mm][0], lam[1] * vec[mm][1]};
      double rot[2][2], deps[2][2];
      for (int a = 0; a < 2; ++a)
        for (int bb = 0; bb < 2; ++bb)
          rot[a][bb] = w_log[a][bb] * (v[a] * w[bb] + w[a] * v[bb]);
      for (int x = 0; x < 2; ++x)
        for (int y = 0; y < 2; ++y) {
          double sum = 0.0;
          for (int a = 0; a < 2; ++a)
            for (int bb = 0; bb < 2; ++bb)
              sum += vec[x][a] * rot[a][bb] * vec[y][bb];
          deps[x][y] = 0.5 * sum;
        }
      d_strain[0][col] = deps[0][0];
      d_strain[1][col] = deps[1][1];
      d_strain[3][col] = deps[0][1] + deps[1][0];  // engineering shear
    }
  d_strain[2][TT] = 1.0;  // d eps_tt = h_tt
  for (int c = 0; c < 4; ++c)
    for (int kk = 0; kk < COMPS; ++kk) {
      double sum = 0.0;
      for (int d = 0; d < 4; ++d)
        sum += d_ep[c][d] * d_strain[d][kk];
      a_mat[c][kk] = sum;
    }
  for (int kk = 0; kk < COMPS; ++kk)  // tau_rz meets both g_rz and g_zr (SYM)
    a_mat[4][kk] = a_mat[3][kk];
}

// A (5x5) with g . A h = -tau : (g h) + shift tr(g h) (finite_strain.geometric_tangent).
void geometric_tangent(const double stress[4], double mean_shift, double a[COMPS][COMPS])
{
  const double tau[2][2] = {{stress[0], stress[3]}, {stress[3], stress[1]}};
  for (int i = 0; i < COMPS; ++i)
    for (int j = 0; j < COMPS; ++j)
      a[i][j] = 0.0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k)
        a[IN_PLANE[i][k]][IN_PLANE[k][j]] -= tau[i][j];
  a[TT][TT] -= stress[2];
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 2; ++k)
      a[IN_PLANE[i][k]][IN_PLANE[k][i]] += mean_shift;
  a[TT][TT] += mean_shift;
}

// One point's share of an element matrix, g_bar^T A_mat g_bar + g^T A_geo g (times dv), with
// g_bar = g + e s^T (e = [1, 1, 1, 0, 0]: the F-bar shift s_j of the trace): expanded as
// g^T (A_mat + A_geo) g + x s^T + s (y + alpha s)^T with x = g^T A_mat e, y = g^T A_mat^T e and
// alpha = e^T A_mat e, one 5x5 product instead of two. Compiled for AVX2/FMA as well as for
// any x86-64 (the loader picks the clone the CPU runs; FMA changes only the round-off).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("arch=x86-64-v3", "default")))
#endif
void add_point_matrix(const double (&g)[COMPS][LOCAL], const double (&shift)[LOCAL],
                      const double (&a_mat)[COMPS][COMPS], const double (&a_geo)[COMPS][COMPS],
                      double dv, double *__restrict local)
{
  double a[COMPS][COMPS], v[COMPS], w[COMPS], alpha = 0.0;
  for (int c = 0; c < COMPS; ++c) {
    v[c] = (a_mat[c][RR] + a_mat[c][ZZ] + a_mat[c][TT]) * dv;
    w[c] = (a_mat[RR][c] + a_mat[ZZ][c] + a_mat[TT][c]) * dv;
    for (int d = 0; d < COMPS; ++d)
      a[c][d] = (a_mat[c][d] + a_geo[c][d]) * dv;
  }
  alpha = v[RR] + v[ZZ] + v[TT];
  double ag[COMPS][LOCAL], x[LOCAL], y[LOCAL];
  for (int k = 0; k < LOCAL; ++k) {
    double xk = 0.0, yk = alpha * shift[k];
    for (int c = 0; c < COMPS; ++c) {
      xk += g[c][k] * v[c];
      yk += g[c][k] * w[c];
    }
    x[k] = xk;
    y[k] = yk;
  }
  for (int c = 0; c < COMPS; ++c)
    for (int k = 0; k < LOCAL; ++k)
      ag[c][k] = a[c][0] * g[0][k] + a[c][1] * g[1][k] + a[c][2] * g[2][k] + a[c][3] * g[3][k] +
                 a[c][4] * g[4][k];
  for (int j = 0; j < LOCAL; ++j) {
    double *__restrict row = local + j * LOCAL;
    const double g0 = g[0][j], g1 = g[1][j], g2 = g[2][j], g3 = g[3][j], g4 = g[4][j];
    const double xj = x[j], sj = shift[j];
    for (int k = 0; k < LOCAL; ++k)
      row[k] += g0 * ag[0][k] + g1 * ag[1][k] + g2 * ag[2][k] + g3 * ag[3][k] + g4 * ag[4][k] +
                xj * shift[k] + sj * y[k];
  }
}

void require(bool ok, const char *kernel, const char *what)
{
  if (!ok)
    throw std::invalid_argument(std::string("fem._kernels.") + kernel + ": " + what);
}

// The arguments both kernels assemble with, checked (element dofs (e, 12) within the
// displacement, force (ndofs,), element matrices (e, 12, 12) or empty), and the force zeroed.
// Returns whether the element matrices are asked for.
bool prepare_assembly(const char *kernel, Array<const int64_t, 2> element_dofs, std::size_t ne,
                      std::size_t ndofs, Array<double, 1> force, Array<double, 3> local)
{
  require(element_dofs.shape(0) == ne && element_dofs.shape(1) == LOCAL, kernel,
          "element_dofs (e, 12)");
  require(force.shape(0) == ndofs, kernel, "force (ndofs,)");
  const bool tangent = local.size() > 0;
  require(!tangent || (local.shape(0) == ne && local.shape(1) == LOCAL &&
                       local.shape(2) == LOCAL), kernel, "local (e, 12, 12)");
  const int64_t *dofs = element_dofs.data();
  for (std::size_t i = 0; i < ne * LOCAL; ++i)
    require(dofs[i] >= 0 && static_cast<std::size_t>(dofs[i]) < ndofs, kernel,
            "dof out of range");
  double *f = force.data();
  for (std::size_t i = 0; i < ndofs; ++i)
    f[i] = 0.0;
  return tangent;
}

// The element's displacements u_e from the global vector.
void gather(const double *u, const int64_t *edofs, double (&ue)[LOCAL])
{
  for (int j = 0; j < LOCAL; ++j)
    ue[j] = u[edofs[j]];
}

// One Newton iterate of the finite-strain solver (FiniteStrainSolver._evaluate): every output
// array is written over. `local` of size 0 skips the tangent (internal force only).
void finite_strain(Array<const double, 4> grad0, Array<const int64_t, 2> element_dofs,
                   Array<const double, 1> displacement, Array<const double, 3> projection,
                   Array<const double, 2> dvolume, Array<const double, 3> cp_old,
                   Array<const double, 2> eqps_old, double shear, double bulk, double tan_beta,
                   double yield_stress, double hardening, bool plastic,
                   Array<double, 3> stress, Array<double, 3> cp, Array<double, 2> eqps,
                   Array<int8_t, 2> status, Array<double, 3> plastic_strain,
                   Array<double, 1> force, Array<double, 3> local)
{
  const std::size_t ne = grad0.shape(0), nq = grad0.shape(1), ndofs = displacement.shape(0);
  const char *kernel = "finite_strain";
  require(grad0.shape(2) == COMPS && grad0.shape(3) == LOCAL, kernel,
          "grad0 must be (e, q, 5, 12)");
  require(nq <= MAX_POINTS, kernel, "too many quadrature points");
  require(projection.shape(0) == ne && projection.shape(1) == nq && projection.shape(2) == nq,
          kernel, "projection (e, q, q)");
  require(dvolume.shape(0) == ne && dvolume.shape(1) == nq, kernel, "dvolume (e, q)");
  for (auto shape : {cp_old.shape(0), stress.shape(0), cp.shape(0), plastic_strain.shape(0)})
    require(shape == 4, kernel, "point tensors (4, e, q)");
  for (auto shape : {cp_old.shape(1), stress.shape(1), cp.shape(1), plastic_strain.shape(1)})
    require(shape == ne, kernel, "point tensors (4, e, q)");
  require(eqps_old.shape(0) == ne && eqps.shape(0) == ne && status.shape(0) == ne, kernel,
          "(e, q)");
  const bool tangent = prepare_assembly(kernel, element_dofs, ne, ndofs, force, local);
  const int64_t *dofs = element_dofs.data();

  const DruckerPrager model{shear, bulk, tan_beta, yield_stress, hardening};
  double d_el[4][4];
  elastic_matrix(model, d_el);
  const double *u = displacement.data();
  const std::size_t field = ne * nq;  // stride of a component of a (4, e, q) field
  double *f = force.data();

  double h[MAX_POINTS][COMPS], log_j[MAX_POINTS], hoop[MAX_POINTS];
  double g[MAX_POINTS][COMPS][LOCAL], trace[MAX_POINTS][LOCAL];
  double g_bar[COMPS][LOCAL], shift[LOCAL];
  double mean_stress[MAX_POINTS];
  double a_mat[MAX_POINTS][COMPS][COMPS];
  for (std::size_t e = 0; e < ne; ++e) {
    const int64_t *edofs = dofs + e * LOCAL;
    double ue[LOCAL];
    gather(u, edofs, ue);
    const double *proj = projection.data() + e * nq * nq;
    const double *dv = dvolume.data() + e * nq;
    // kinematics: H = F - I, ln J, spatial gradients g = Grad N F^-1 (hoop N / r)
    for (std::size_t q = 0; q < nq; ++q) {
      const double *G0 = grad0.data() + (e * nq + q) * COMPS * LOCAL;
      for (int c = 0; c < COMPS; ++c) {
        double sum = 0.0;
        for (int j = 0; j < LOCAL; ++j)
          sum += G0[c * LOCAL + j] * ue[j];
        h[q][c] = sum;
      }
      const double *H = h[q];
      log_j[q] = std::log1p(H[RR] + H[ZZ] + H[RR] * H[ZZ] - H[RZ] * H[ZR]) + std::log1p(H[TT]);
      const double fm[2][2] = {{1.0 + H[RR], H[RZ]}, {H[ZR], 1.0 + H[ZZ]}};
      double finv[2][2];
      inverse2(fm, finv);
      for (int i = 0; i < 2; ++i)
        for (int k = 0; k < 2; ++k) {
          const double *g_i0 = G0 + IN_PLANE[i][0] * LOCAL, *g_i1 = G0 + IN_PLANE[i][1] * LOCAL;
          double *out = g[q][IN_PLANE[i][k]];
          for (int j = 0; j < LOCAL; ++j)
            out[j] = g_i0[j] * finv[0][k] + g_i1[j] * finv[1][k];
        }
      hoop[q] = 1.0 + H[TT];
      for (int j = 0; j < LOCAL; ++j) {
        g[q][TT][j] = G0[TT * LOCAL + j] / hoop[q];
        trace[q][j] = g[q][RR][j] + g[q][ZZ][j] + g[q][TT][j];
      }
    }
    // F-bar: (J_bar / J)^(1/3), the test gradients' trace projected the same way
    for (std::size_t q = 0; q < nq; ++q) {
      double projected = 0.0;
      for (std::size_t p = 0; p < nq; ++p)
        projected += proj[q * nq + p] * log_j[p];
      const double scale_minus = std::expm1((projected - log_j[q]) / 3.0);
      double h_bar[COMPS];
      for (int c = 0; c < COMPS; ++c)
        h_bar[c] = h[q][c] * (1.0 + scale_minus);
      h_bar[RR] += scale_minus;
      h_bar[ZZ] += scale_minus;
      h_bar[TT] += scale_minus;
      const std::size_t point = e * nq + q;
      double old[4];
      for (int c = 0; c < 4; ++c)
        old[c] = cp_old.data()[c * field + point];
      PointResult r;
      point_update(model, d_el, h_bar, old, eqps_old.data()[point], plastic, r,
                   tangent ? a_mat[q] : nullptr);
      for (int c = 0; c < 4; ++c) {
        stress.data()[c * field + point] = r.stress[c];
        cp.data()[c * field + point] = r.cp[c];
        plastic_strain.data()[c * field + point] = r.plastic_strain[c];
      }
      eqps.data()[point] = r.eqps;
      status.data()[point] = r.status;
      mean_stress[q] = (r.stress[0] + r.stress[1] + r.stress[2]) / 3.0;
    }
    // internal force: integral of tau : g_bar dV0, and the element matrix
    double *ke = tangent ? local.data() + e * LOCAL * LOCAL : nullptr;
    if (tangent)
      for (int i = 0; i < LOCAL * LOCAL; ++i)
        ke[i] = 0.0;
    double fe[LOCAL] = {};
    for (std::size_t q = 0; q < nq; ++q) {
      for (int j = 0; j < LOCAL; ++j) {
        double projected = 0.0;
        for (std::size_t p = 0; p < nq; ++p)
          projected += proj[q * nq + p] * trace[p][j];
        shift[j] = (projected - trace[q][j]) / 3.0;
        for (int c = 0; c < COMPS; ++c)
          g_bar[c][j] = g[q][c][j] + (c <= TT ? shift[j] : 0.0);
      }
      const std::size_t point = e * nq + q;
      const double *s = stress.data() + point;
      const double tau5[COMPS] = {s[0], s[field], s[2 * field], s[3 * field], s[3 * field]};
      for (int j = 0; j < LOCAL; ++j) {
        double sum = 0.0;
        for (int c = 0; c < COMPS; ++c)
          sum += g_bar[c][j] * tau5[c];
        fe[j] += sum * dv[q];
      }
      if (!tangent)
        continue;
      double projected_mean = 0.0;
      for (std::size_t p = 0; p < nq; ++p)
        projected_mean += proj[q * nq + p] * mean_stress[p];
      const double tau4[4] = {tau5[0], tau5[1], tau5[2], tau5[3]};
      double a_geo[COMPS][COMPS];
      geometric_tangent(tau4, mean_stress[q] - projected_mean, a_geo);
      add_point_matrix(g[q], shift, a_mat[q], a_geo, dv[q], ke);
    }
    for (int j = 0; j < LOCAL; ++j)
      f[edofs[j]] += fe[j];
  }
}

// --- small strain (fem/solver.py ContactSolver) ------------------------------------------------
// One Newton iterate of the small-strain engine (ContactSolver._response and element_matrices):
// at every point the strain B u_e (B the engine's strain matrices, the B-bar projection of the
// volumetric strain already in them: ContactSolver._strain_matrices), the trial stress
// sigma_old + D (eps - eps_old), the Drucker-Prager return mapping with its consistent tangent
// (plasticity.return_mapping; without `plastic` the trial stress, status elastic), the internal
// force sum B^T sigma dV and, if `local` is not empty, the element matrices sum B^T D_ep B dV.
// Layouts: strain matrices (elements, points, 4, 12); point fields (4, elements, points).

// K_e += B^T (D dv) B, upper triangle only (D symmetric: associated flow; mirrored by the caller).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("arch=x86-64-v3", "default")))
#endif
void add_small_strain_matrix(const double *__restrict b, const double (&d)[4][4], double dv,
                             double *__restrict local)
{
  double db[4][LOCAL];  // (D dv) B
  for (int c = 0; c < 4; ++c) {
    const double d0 = d[c][0] * dv, d1 = d[c][1] * dv, d2 = d[c][2] * dv, d3 = d[c][3] * dv;
    for (int k = 0; k < LOCAL; ++k)
      db[c][k] = d0 * b[k] + d1 * b[LOCAL + k] + d2 * b[2 * LOCAL + k] + d3 * b[3 * LOCAL + k];
  }
  for (int j = 0; j < LOCAL; ++j) {
    const double b0 = b[j], b1 = b[LOCAL + j], b2 = b[2 * LOCAL + j], b3 = b[3 * LOCAL + j];
    double *__restrict row = local + j * LOCAL;
    for (int k = j; k < LOCAL; ++k)
      row[k] += b0 * db[0][k] + b1 * db[1][k] + b2 * db[2][k] + b3 * db[3][k];
  }
}

void small_strain(Array<const double, 4> strain_matrices, Array<const int64_t, 2> element_dofs,
                  Array<const double, 1> displacement, Array<const double, 2> dvolume,
                  Array<const double, 3> stress_old, Array<const double, 3> strain_old,
                  Array<const double, 2> eqps_old, double shear, double bulk, double tan_beta,
                  double yield_stress, double hardening, bool plastic,
                  Array<double, 3> stress, Array<double, 3> strain, Array<double, 2> eqps,
                  Array<int8_t, 2> status, Array<double, 1> force, Array<double, 3> local)
{
  const std::size_t ne = strain_matrices.shape(0), nq = strain_matrices.shape(1);
  const std::size_t ndofs = displacement.shape(0);
  const char *kernel = "small_strain";
  require(strain_matrices.shape(2) == 4 && strain_matrices.shape(3) == LOCAL, kernel,
          "strain_matrices must be (e, q, 4, 12)");
  require(dvolume.shape(0) == ne && dvolume.shape(1) == nq, kernel, "dvolume (e, q)");
  for (auto *field : {&stress_old, &strain_old})
    require(field->shape(0) == 4 && field->shape(1) == ne && field->shape(2) == nq, kernel,
            "point tensors (4, e, q)");
  for (auto *field : {&stress, &strain})
    require(field->shape(0) == 4 && field->shape(1) == ne && field->shape(2) == nq, kernel,
            "point tensors (4, e, q)");
  require(eqps_old.shape(0) == ne && eqps_old.shape(1) == nq && eqps.shape(0) == ne &&
          eqps.shape(1) == nq && status.shape(0) == ne && status.shape(1) == nq, kernel,
          "(e, q)");
  const bool tangent = prepare_assembly(kernel, element_dofs, ne, ndofs, force, local);
  const int64_t *dofs = element_dofs.data();

  const DruckerPrager model{shear, bulk, tan_beta, yield_stress, hardening};
  double d_el[4][4];
  elastic_matrix(model, d_el);
  const double *u = displacement.data();
  const std::size_t field = ne * nq;  // stride of a component of a (4, e, q) field
  double *f = force.data();
  for (std::size_t e = 0; e < ne; ++e) {
    const int64_t *edofs = dofs + e * LOCAL;
    double ue[LOCAL];
    gather(u, edofs, ue);
    const double *dv = dvolume.data() + e * nq;
    double *ke = tangent ? local.data() + e * LOCAL * LOCAL : nullptr;
    if (tangent)
      for (int i = 0; i < LOCAL * LOCAL; ++i)
        ke[i] = 0.0;
    double fe[LOCAL] = {};
    for (std::size_t q = 0; q < nq; ++q) {
      const std::size_t point = e * nq + q;
      const double *b = strain_matrices.data() + point * 4 * LOCAL;
      double d_eps[4];
      for (int c = 0; c < 4; ++c) {
        double sum = 0.0;
        for (int j = 0; j < LOCAL; ++j)
          sum += b[c * LOCAL + j] * ue[j];
        strain.data()[c * field + point] = sum;
        d_eps[c] = sum - strain_old.data()[c * field + point];
      }
      double trial[4];
      for (int c = 0; c < 4; ++c)
        trial[c] = stress_old.data()[c * field + point] +
                   (d_el[c][0] * d_eps[0] + d_el[c][1] * d_eps[1] + d_el[c][2] * d_eps[2] +
                    d_el[c][3] * d_eps[3]);
      const double eqps_prev = eqps_old.data()[point];
      double s[4], d_ep[4][4], eqps_new = eqps_prev;
      signed char state = ELASTIC;
      if (plastic) {
        state = return_mapping(model, trial, eqps_prev, s, eqps_new, tangent ? d_ep : nullptr);
      } else {
        for (int c = 0; c < 4; ++c) {
          s[c] = trial[c];
          for (int d = 0; d < 4; ++d)
            d_ep[c][d] = d_el[c][d];
        }
      }
      for (int c = 0; c < 4; ++c)
        stress.data()[c * field + point] = s[c];
      eqps.data()[point] = eqps_new;
      status.data()[point] = state;
      for (int j = 0; j < LOCAL; ++j)
        fe[j] += (b[j] * s[0] + b[LOCAL + j] * s[1] + b[2 * LOCAL + j] * s[2] +
                  b[3 * LOCAL + j] * s[3]) * dv[q];
      if (tangent)
        add_small_strain_matrix(b, d_ep, dv[q], ke);
    }
    if (tangent)
      for (int j = 0; j < LOCAL; ++j)
        for (int k = 0; k < j; ++k)
          ke[j * LOCAL + k] = ke[k * LOCAL + j];
    for (int j = 0; j < LOCAL; ++j)
      f[edofs[j]] += fe[j];
  }
}

// out = 0, then out[slot[i]] += weight[i] * values[i] for slot[i] >= 0: element matrices into
// the data of a fixed sparse pattern (an empty `weight` means all ones).
void scatter(Array<const double, 1> values, Array<const int64_t, 1> slot,
             Array<const double, 1> weight, Array<double, 1> out)
{
  const std::size_t n = values.shape(0), m = out.shape(0);
  require(slot.shape(0) == n && (weight.size() == 0 || weight.shape(0) == n), "scatter",
          "values, slot and weight differ in size");
  const int64_t *s = slot.data();
  for (std::size_t i = 0; i < n; ++i)
    require(s[i] < static_cast<int64_t>(m), "scatter", "slot out of range");
  double *o = out.data();
  for (std::size_t i = 0; i < m; ++i)
    o[i] = 0.0;
  const double *v = values.data();
  if (weight.size() == 0) {
    for (std::size_t i = 0; i < n; ++i)
      if (s[i] >= 0)
        o[s[i]] += v[i];
  } else {
    const double *w = weight.data();
    for (std::size_t i = 0; i < n; ++i)
      if (s[i] >= 0)
        o[s[i]] += w[i] * v[i];
  }
}

}  // namespace

NB_MODULE(_kernels, module)
{
  module.doc() = "Compiled small- and finite-strain element kernels of the FE (fem/compiled.py).";
  module.attr("SOURCE_HASH") = GEOCONTACT_KERNELS_HASH;  // sha256 of this file (CMakeLists.txt)
  module.def("finite_strain", &finite_strain, "grad0"_a, "element_dofs"_a, "displacement"_a,
             "projection"_a, "dvolume"_a, "cp_old"_a, "eqps_old"_a, "shear"_a, "bulk"_a,
             "tan_beta"_a, "yield_stress"_a, "hardening"_a, "plastic"_a, "stress"_a, "cp"_a,
             "eqps"_a, "status"_a, "plastic_strain"_a, "force"_a, "local"_a,
             nb::call_guard<nb::gil_scoped_release>());
  module.def("small_strain", &small_strain, "strain_matrices"_a, "element_dofs"_a,
             "displacement"_a, "dvolume"_a, "stress_old"_a, "strain_old"_a, "eqps_old"_a,
             "shear"_a, "bulk"_a, "tan_beta"_a, "yield_stress"_a, "hardening"_a, "plastic"_a,
             "stress"_a, "strain"_a, "eqps"_a, "status"_a, "force"_a, "local"_a,
             nb::call_guard<nb::gil_scoped_release>());
  module.def("scatter", &scatter, "values"_a, "slot"_a, "weight"_a, "out"_a,
             nb::call_guard<nb::gil_scoped_release>());
}
