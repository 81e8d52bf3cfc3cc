// geocontact.fem._sparse_lu: SuiteSparse's UMFPACK and KLU (the Debian/Ubuntu libsuitesparse-dev
// that `make` installs for CHOLMOD) for the unsymmetric finite-strain tangent (issue 36), with
// the symbolic analysis (fill-reducing ordering) of a sparsity pattern done once and reused by
// every numeric factorisation of that pattern, which scipy's SuperLU cannot do. Built only when
// CMake finds the library (CMakeLists.txt); fem/compiled.py falls back to SuperLU without it.
//
// A factoriser is made for one CSC pattern (indptr, indices; int64, sorted), `factor(data)`
// factorises the matrix with that pattern and those values, `solve(rhs)` solves with the last
// factorisation. Errors (a singular matrix) come back as a false `factor`, never an exception
// in the middle of a Newton iteration.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <klu.h>
#include <umfpack.h>

#include <cstdint>
#include <stdexcept>
#include <vector>

namespace nb = nanobind;
using namespace nb::literals;

namespace {

template <class T>
using Vector = nb::ndarray<T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

struct Pattern {
  int64_t n = 0;
  std::vector<int64_t> indptr, indices;

  Pattern(Vector<const int64_t> p, Vector<const int64_t> i)
      : n(static_cast<int64_t>(p.shape(0)) - 1), indptr(p.data(), p.data() + p.shape(0)),
        indices(i.data(), i.data() + i.shape(0))
  {
    if (n < 1 || indptr.front() != 0 || indptr.back() != static_cast<int64_t>(indices.size()))
      throw std::invalid_argument("fem._sparse_lu: not a CSC pattern");
    for (int64_t k : indices)
      if (k < 0 || k >= n)
        throw std::invalid_argument("fem._sparse_lu: row index out of range");
  }

  void check(Vector<const double> data) const
  {
    if (data.shape(0) != indices.size())
      throw std::invalid_argument("fem._sparse_lu: data do not fit the pattern");
  }

  void check_rhs(Vector<const double> rhs) const
  {
    if (static_cast<int64_t>(rhs.shape(0)) != n)
      throw std::invalid_argument("fem._sparse_lu: right-hand side of the wrong size");
  }
};

nb::ndarray<nb::numpy, double, nb::ndim<1>> new_vector(std::size_t n, double *&data)
{
  data = new double[n];
  nb::capsule owner(data, [](void *p) noexcept { delete[] static_cast<double *>(p); });
  return nb::ndarray<nb::numpy, double, nb::ndim<1>>(data, {n}, owner);
}

// UMFPACK (Davis 2004): multifrontal LU; its "auto" strategy takes the symmetric one (AMD on
// A + A^T, diagonal pivots preferred) for this structurally symmetric matrix.
class Umfpack {
public:
  Umfpack(Vector<const int64_t> indptr, Vector<const int64_t> indices) : pattern_(indptr, indices)
  {
    umfpack_dl_defaults(control_);
  }
  ~Umfpack()
  {
    if (numeric_)
      umfpack_dl_free_numeric(&numeric_);
    if (symbolic_)
      umfpack_dl_free_symbolic(&symbolic_);
  }
  Umfpack(const Umfpack &) = delete;
  Umfpack &operator=(const Umfpack &) = delete;

  bool factor(Vector<const double> data)
  {
    pattern_.check(data);
    values_.assign(data.data(), data.data() + data.shape(0));
    const int64_t *p = pattern_.indptr.data(), *i = pattern_.indices.data();
    if (numeric_)
      umfpack_dl_free_numeric(&numeric_);
    if (!symbolic_ && umfpack_dl_symbolic(pattern_.n, pattern_.n, p, i, values_.data(), &symbolic_,
                                          control_, nullptr) != UMFPACK_OK) {
      symbolic_ = nullptr;
      return false;
    }
    const int status = umfpack_dl_numeric(p, i, values_.data(), symbolic_, &numeric_, control_,
                                          nullptr);
    if (status != UMFPACK_OK) {  // singular (UMFPACK_WARNING_singular_matrix is > 0) or error
      if (numeric_)
        umfpack_dl_free_numeric(&numeric_);
      numeric_ = nullptr;
      return false;
    }
    ++factorisations_;
    return true;
  }

  nb::ndarray<nb::numpy, double, nb::ndim<1>> solve(Vector<const double> rhs)
  {
    if (!numeric_)
      throw std::runtime_error("fem._sparse_lu: solve before a successful factor");
    pattern_.check_rhs(rhs);
    double *x = nullptr;
    auto out = new_vector(pattern_.n, x);
    umfpack_dl_solve(UMFPACK_A, pattern_.indptr.data(), pattern_.indices.data(), values_.data(),
                     x, rhs.data(), numeric_, control_, nullptr);
    return out;
  }

  bool analysed() const { return symbolic_ != nullptr; }
  int factorisations() const { return factorisations_; }

private:
  Pattern pattern_;
  std::vector<double> values_;
  double control_[UMFPACK_CONTROL];
  void *symbolic_ = nullptr, *numeric_ = nullptr;
  int factorisations_ = 0;
};

// KLU (Davis & Palamadai Natarajan 2010): BTF + AMD ordering, left-looking Gilbert-Peierls LU with
// partial pivoting; no BLAS.
class Klu {
public:
  Klu(Vector<const int64_t> indptr, Vector<const int64_t> indices) : pattern_(indptr, indices)
  {
    klu_l_defaults(&common_);
  }
  ~Klu()
  {
    if (numeric_)
      klu_l_free_numeric(&numeric_, &common_);
    if (symbolic_)
      klu_l_free_symbolic(&symbolic_, &common_);
  }
  Klu(const Klu &) = delete;
  Klu &operator=(const Klu &) = delete;

  bool factor(Vector<const double> data)
  {
    pattern_.check(data);
    int64_t *p = pattern_.indptr.data(), *i = pattern_.indices.data();
    if (numeric_)
      klu_l_free_numeric(&numeric_, &common_);
    if (!symbolic_)
      symbolic_ = klu_l_analyze(pattern_.n, p, i, &common_);
    if (!symbolic_)
      return false;
    numeric_ = klu_l_factor(p, i, const_cast<double *>(data.data()), symbolic_, &common_);
    if (!numeric_ || common_.status != KLU_OK) {
      if (numeric_)
        klu_l_free_numeric(&numeric_, &common_);
      numeric_ = nullptr;
      return false;
    }
    ++factorisations_;
    return true;
  }

  nb::ndarray<nb::numpy, double, nb::ndim<1>> solve(Vector<const double> rhs)
  {
    if (!numeric_)
      throw std::runtime_error("fem._sparse_lu: solve before a successful factor");
    pattern_.check_rhs(rhs);
    double *x = nullptr;
    auto out = new_vector(pattern_.n, x);
    for (int64_t k = 0; k < pattern_.n; ++k)
      x[k] = rhs.data()[k];
    klu_l_solve(symbolic_, numeric_, pattern_.n, 1, x, &common_);
    return out;
  }

  bool analysed() const { return symbolic_ != nullptr; }
  int factorisations() const { return factorisations_; }

private:
  Pattern pattern_;
  klu_l_common common_;
  klu_l_symbolic *symbolic_ = nullptr;
  klu_l_numeric *numeric_ = nullptr;
  int factorisations_ = 0;
};

template <class Solver>
void bind(nb::module_ &module, const char *name, const char *doc)
{
  nb::class_<Solver>(module, name, doc)
      .def(nb::init<Vector<const int64_t>, Vector<const int64_t>>(), "indptr"_a, "indices"_a)
      .def("factor", &Solver::factor, "data"_a, nb::call_guard<nb::gil_scoped_release>(),
           "Factorise the matrix of this pattern with these values (CSC data); False if "
           "singular.")
      .def("solve", &Solver::solve, "rhs"_a, "Solve with the last factorisation.")
      .def_prop_ro("analysed", &Solver::analysed)
      .def_prop_ro("factorisations", &Solver::factorisations);
}

}  // namespace

NB_MODULE(_sparse_lu, module)
{
  module.doc() = "UMFPACK and KLU with the symbolic analysis reused per sparsity pattern.";
  bind<Umfpack>(module, "Umfpack", "UMFPACK LU of one CSC sparsity pattern.");
  bind<Klu>(module, "Klu", "KLU LU of one CSC sparsity pattern.");
}
