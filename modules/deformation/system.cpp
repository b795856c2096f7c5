#include <diffreg/deformation/system.h>

#include <diffreg/core/error.h>
#include <diffreg/core/incidence.h>
#include <diffreg/core/parallel.h>
#include <diffreg/core/sparse_entry.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

namespace diffreg {

namespace {

// A scatter colour's elements per chunk (a colour holds a tenth to a thirtieth of the
// elements: small chunks keep both threads busy).
constexpr int kColourGrain = 256;
// Scatter groups of consecutive elements (RegularizedSystem::scatterGroups), and the fewest
// groups per colour on average for which they are used instead of single elements.
constexpr int kScatterGroup = 256;
constexpr int kGroupsPerColour = 4;
constexpr int kMaxBlock = 9;  // rows() x columns() of any energy: 3 x 3, 2 x 2, 9 x 1 or 4 x 1

// Adds the shares L_k^T tau_k of the elements `ids[0..count)` (or, without ids, the elements
// first .. first + count - 1) to the rows of b, one after the other, with
// tau_k = w_k v_k + sum_(facets kl) w_kl (v_k - v_l) for v = t, or v = F - t (Residual).
// Concurrent calls on element sets that share no unknown (one scatter colour) do not race. R rows,
// C columns and U local unknowns per element: known at compile time for the separable layouts (>
// 0), else `r`, `c`, `u` at run time.
template <int R, int C, int U, bool Residual>
void scatterShares(const ResidualModel& model, const Stacked& t, const Stacked* F,
                   const Regularizer& reg, int r_, int c_, int u_, const int* ids, int first,
                   int count, Eigen::MatrixXd& b) {
  const int r = R > 0 ? R : r_, c = C > 0 ? C : c_, u = U > 0 ? U : u_;
  const ResidualModel::Operators L = model.operators();
  const Eigen::VectorXd& wk = reg.elementWeight();
  const bool coupled = reg.coupling();
  auto value = [&](Eigen::Index row, int col) {
    return Residual ? (*F)(row, col) - t(row, col) : t(row, col);
  };
  double tau[kMaxBlock];  // [col][a]
  for (int i = 0; i < count; ++i) {
    const int k = ids ? ids[i] : first + i;
    const Eigen::Index row = static_cast<Eigen::Index>(k) * r;
    const double w = wk(k);
    for (int col = 0; col < c; ++col)
      for (int a = 0; a < r; ++a) tau[col * r + a] = w * value(row + a, col);
    if (coupled)
      for (int g = reg.facetBegin(k); g < reg.facetEnd(k); ++g) {
        const double wg = reg.neighbourWeight(g);
        const Eigen::Index other = static_cast<Eigen::Index>(reg.neighbour(g)) * r;
        for (int col = 0; col < c; ++col)
          for (int a = 0; a < r; ++a)
            tau[col * r + a] += wg * (value(row + a, col) - value(other + a, col));
      }
    for (int j = 0; j < u; ++j) {
      double Lj[kMaxBlock];  // column j of L_k
      for (int a = 0; a < r; ++a) Lj[a] = L(k, a, j);
      const Eigen::Index p = model.unknown(k, j);
      for (int col = 0; col < c; ++col) {
        double sum = 0.0;
        for (int a = 0; a < r; ++a) sum += Lj[a] * tau[col * r + a];
        b(p, col) += sum;
      }
    }
  }
}

template <int R, int C, int U>
void scatterShares(const ResidualModel& model, const Stacked& t, const Stacked* F,
                   const Regularizer& reg, int r, int c, int u, const int* ids, int first,
                   int count, Eigen::MatrixXd& b) {
  if (F)
    scatterShares<R, C, U, true>(model, t, F, reg, r, c, u, ids, first, count, b);
  else
    scatterShares<R, C, U, false>(model, t, F, reg, r, c, u, ids, first, count, b);
}

// Adds w B^T B to A's values for a block B of r rows whose columns are the unknowns ids[0, n),
// stored [column][row] (R > 0: r known at compile time). Each entry sums its rows in order;
// (i, j) and (j, i) get the same sum, computed once. A's pattern holds every pair of ids.
template <int R>
inline void addGram(const int* ids, const double* B, int n, int r_, double w, SparseMatrix& A) {
  const int r = R > 0 ? R : r_;
  double* values = A.valuePtr();
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  for (int j = 0; j < n; ++j)
    for (int i = 0; i <= j; ++i) {
      double sum = 0.0;
      for (int row = 0; row < r; ++row) sum += B[i * r + row] * B[j * r + row];
      values[entryIndex(outer, inner, ids[i], ids[j])] += w * sum;
      if (i != j) values[entryIndex(outer, inner, ids[j], ids[i])] += w * sum;
    }
}

// Adds w_k L_k^T L_k of every element with w_k != 0 to A's values (A's pattern holds every
// element's unknowns). R rows and U local unknowns per element: known at compile time (> 0) for
// the common layouts, else `r`, `u` at run time. The elements in order, whatever R and U.
template <int R, int U>
void addElementBlocks(const ResidualModel& model, const Eigen::VectorXd& elementWeight, int r_,
                      int u_, SparseMatrix& A) {
  const int r = R > 0 ? R : r_, u = U > 0 ? U : u_;
  const int m = model.discretization().numElements();
  const ResidualModel::Operators L = model.operators();
  int ids[4 * kMaxBlock];
  double Lk[kMaxBlock * 4 * kMaxBlock];  // [j][row]
  for (int k = 0; k < m; ++k) {
    const double w = elementWeight(k);
    if (w == 0.0) continue;
    for (int j = 0; j < u; ++j) {
      ids[j] = model.unknown(k, j);
      for (int row = 0; row < r; ++row) Lk[j * r + row] = L(k, row, j);
    }
    addGram<R>(ids, Lk, u, r, w, A);
  }
}

// Adds ell beta_kl c_kl (L_k - L_l)^T (L_k - L_l) of every facet with a nonzero weight to A's
// values, over the union of its two elements' unknowns (sizes as addElementBlocks).
template <int R, int U>
void addFacetBlocks(const ResidualModel& model, const std::vector<Facet>& facets,
                    const Eigen::VectorXd& facetWeight, int r_, int u_, SparseMatrix& A) {
  const int r = R > 0 ? R : r_, u = U > 0 ? U : u_;
  const ResidualModel::Operators L = model.operators();
  int ids[8 * kMaxBlock];
  double M[kMaxBlock * 8 * kMaxBlock];  // [unknown][row]
  for (size_t f = 0; f < facets.size(); ++f) {
    const double w = facetWeight(static_cast<Eigen::Index>(f));
    if (w == 0.0) continue;
    const Facet& fc = facets[f];
    int n = u;
    for (int j = 0; j < u; ++j) {
      ids[j] = model.unknown(fc.k, j);
      for (int row = 0; row < r; ++row) M[j * r + row] = L(fc.k, row, j);
    }
    for (int j = 0; j < u; ++j) {
      const int id = model.unknown(fc.l, j);
      int pos = 0;
      while (pos < n && ids[pos] != id) ++pos;
      if (pos == n) {
        ids[n++] = id;
        for (int row = 0; row < r; ++row) M[pos * r + row] = 0.0;
      }
      for (int row = 0; row < r; ++row) M[pos * r + row] -= L(fc.l, row, j);
    }
    addGram<R>(ids, M, n, r, w, A);
  }
}

// The items 0 .. colourOf.size() - 1 grouped by their colour (< colours), each colour's in
// increasing order, as CSR: colour c's items are order[start[c] .. start[c + 1]).
void byColour(const std::vector<int>& colourOf, int colours, std::vector<int>& start,
              std::vector<int>& order) {
  start.assign(static_cast<size_t>(colours) + 1, 0);
  for (int c : colourOf) ++start[static_cast<size_t>(c) + 1];
  for (int c = 0; c < colours; ++c) start[c + 1] += start[c];
  order.resize(colourOf.size());
  std::vector<int> next(start.begin(), start.end() - 1);
  for (size_t i = 0; i < colourOf.size(); ++i)
    order[static_cast<size_t>(next[static_cast<size_t>(colourOf[i])]++)] = static_cast<int>(i);
}

}  // namespace

RegularizedSystem::RegularizedSystem(const ResidualModel& model, SolverBackend backend,
                                     bool reserveCouplings)
    : model_(model),
      regularizer_(model.discretization()),
      reserveCouplings_(reserveCouplings),
      solver_(backend) {
  solver_.trustPatterns();  // buildPattern() is the only place A's pattern changes
  // The element and facet blocks' scratch arrays hold kMaxBlock rows and 4 kMaxBlock unknowns
  // an element (every layout today: at most 9 and 12).
  if (model.rows() > kMaxBlock || model.localSize() > 4 * kMaxBlock)
    throw std::logic_error("RegularizedSystem: a layout of " + std::to_string(model.rows()) +
                           " rows and " + std::to_string(model.localSize()) +
                           " unknowns an element exceeds the blocks' scratch arrays");
  buildTopology();
  setWeights(makeRegularizationWeights(model.discretization(), Regularization::None, 0.0));
}

void RegularizedSystem::setHandles(const std::vector<int>& vertices) {
  handles_ = vertices;
  partitionDirty_ = true;
}

void RegularizedSystem::setWeights(const RegularizationWeights& weights) {
  regularizer_.setWeights(weights);
  const bool couplings = reserveCouplings_ || regularizer_.coupling() || couplings_;
  if (A_.rows() == 0 || couplings != couplings_) buildPattern(couplings);
  valuesDirty_ = true;
  matrixDirty_ = true;
}

void RegularizedSystem::buildTopology() {
  const Discretization& disc = model_.discretization();
  const int m = disc.numElements(), u = model_.localSize(), N = model_.numUnknowns();
  Incidence incidence = incidenceOf(
      N, m, u, [this](int k, int j) { return model_.unknown(k, j); },
      [u](int k, int j) { return k * u + j; });
  incidenceStart_ = std::move(incidence.start);
  incidence_ = std::move(incidence.entries);
  // Scatter colours of groups of kScatterGroup consecutive elements, greedily: the smallest
  // colour (of 64, a bit mask per unknown) that no group sharing an unknown has yet. Used when
  // the groups are compact enough to leave kGroupsPerColour groups per colour on average.
  const int groups = (m + kScatterGroup - 1) / kScatterGroup;
  std::vector<std::uint64_t> used(static_cast<size_t>(N), 0);
  {
    std::vector<int> groupColour(static_cast<size_t>(groups));
    int colours = 0;
    bool fits = true;
    for (int q = 0; q < groups && fits; ++q) {
      const int first = q * kScatterGroup, last = std::min(m, first + kScatterGroup);
      std::uint64_t taken = 0;
      for (int k = first; k < last; ++k)
        for (int j = 0; j < u; ++j) taken |= used[static_cast<size_t>(model_.unknown(k, j))];
      if (~taken == 0) {
        fits = false;
        break;
      }
      int c = 0;
      while (taken & (std::uint64_t{1} << c)) ++c;
      for (int k = first; k < last; ++k)
        for (int j = 0; j < u; ++j)
          used[static_cast<size_t>(model_.unknown(k, j))] |= std::uint64_t{1} << c;
      groupColour[static_cast<size_t>(q)] = c;
      colours = std::max(colours, c + 1);
    }
    if (fits && colours * kGroupsPerColour <= groups) {
      scatterGroup_ = kScatterGroup;
      byColour(groupColour, colours, scatterStart_, scatterOrder_);
      return;
    }
    std::fill(used.begin(), used.end(), 0);
  }
  scatterGroup_ = 1;
  // Otherwise scatter colours of single elements: greedily, the smallest colour that no element
  // sharing an unknown with k has yet (about 10 on triangle meshes, 25-35 on tets). The first 64
  // colours are tracked as a bit mask per unknown; an element that finds them all taken scans its
  // neighbours' colours.
  std::vector<int> colour(static_cast<size_t>(m), -1), counts;
  std::vector<int> stamp;
  for (int k = 0; k < m; ++k) {
    std::uint64_t taken = 0;
    for (int j = 0; j < u; ++j) taken |= used[static_cast<size_t>(model_.unknown(k, j))];
    int c = 0;
    if (~taken != 0) {
      while (taken & (std::uint64_t{1} << c)) ++c;
    } else {
      stamp.assign(counts.size() + 1, 0);
      for (int j = 0; j < u; ++j) {
        const int p = model_.unknown(k, j);
        for (int at = incidenceStart_[p]; at < incidenceStart_[p + 1]; ++at) {
          const int other = colour[static_cast<size_t>(incidence_[at] / u)];
          if (other >= 0) stamp[static_cast<size_t>(other)] = 1;
        }
      }
      c = 64;
      while (stamp[static_cast<size_t>(c)]) ++c;
    }
    if (c < 64)
      for (int j = 0; j < u; ++j)
        used[static_cast<size_t>(model_.unknown(k, j))] |= std::uint64_t{1} << c;
    if (c >= static_cast<int>(counts.size())) counts.resize(static_cast<size_t>(c) + 1, 0);
    colour[static_cast<size_t>(k)] = c;
    ++counts[static_cast<size_t>(c)];
  }
  byColour(colour, static_cast<int>(counts.size()), scatterStart_, scatterOrder_);
}

// Column p of A couples p with every unknown of the elements that touch p and, with the
// facets' couplings, of their neighbours across a facet (the union of a facet's two elements).
void RegularizedSystem::buildPattern(bool couplings) {
  patternChanged_ = true;
  const int u = model_.localSize(), N = model_.numUnknowns();
  const int m = model_.discretization().numElements();
  // Every element's unknowns side by side (the elements' matrix is stored by columns): read
  // once per element around each unknown.
  std::vector<int> unknowns(static_cast<size_t>(m) * u);
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < u; ++j) unknowns[static_cast<size_t>(k) * u + j] = model_.unknown(k, j);
  std::vector<int> outer(static_cast<size_t>(N) + 1, 0);
  // A column holds at most the unknowns of the elements around its unknown and their facet
  // neighbours, repeats included.
  int widest = 0, facets = 0;
  for (int p = 0; p < N; ++p)
    widest = std::max(widest, incidenceStart_[p + 1] - incidenceStart_[p]);
  if (couplings)
    for (int k = 0; k < m; ++k)
      facets = std::max(facets, regularizer_.facetEnd(k) - regularizer_.facetBegin(k));
  // The columns are independent: one run of consecutive columns per thread, each with its own
  // marks, its entries appended to its own part; outer holds the counts within each part first.
  const int threads = parallel::threads();
  const int grain = std::max(kPatternGrain, (N + threads - 1) / threads);
  // The buffers are allocated here, by the calling thread, and filled by the chunk's: memory a
  // worker allocates stays in its own glibc arena (a million-vertex editor session peaked
  // 33 MiB higher). A part's reserve: a column holds about 7 vertices' unknowns without the
  // couplings, 13 with them, against about 6 elements around its vertex.
  const int chunks = parallel::numChunks(N, grain);
  std::vector<std::vector<int>> parts(static_cast<size_t>(chunks)), columns(parts.size());
  std::vector<std::unique_ptr<int[]>> marks(parts.size());
  const size_t perIncidence = static_cast<size_t>(model_.dofsPerVertex()) * (couplings ? 4 : 2);
  for (int c = 0; c < chunks; ++c) {
    const int begin = c * grain, end = std::min(N, begin + grain);
    parts[static_cast<size_t>(c)].reserve(
        static_cast<size_t>(incidenceStart_[end] - incidenceStart_[begin]) * perIncidence);
    marks[static_cast<size_t>(c)].reset(new int[static_cast<size_t>(N)]);
    columns[static_cast<size_t>(c)].resize(static_cast<size_t>(widest) * u * (1 + facets));
  }
  parallel::forChunks(N, grain, [&](int chunk, int begin, int end) {
    int* const mark = marks[static_cast<size_t>(chunk)].get();
    std::fill(mark, mark + N, -1);
    std::vector<int>& column = columns[static_cast<size_t>(chunk)];
    std::vector<int>& inner = parts[static_cast<size_t>(chunk)];
    for (int p = begin; p < end; ++p) {
      // Every unknown is written, and kept (the count advanced) only on its first visit for p:
      // whether an unknown was seen before follows no pattern a branch predictor could learn.
      int count = 0;
      auto addElement = [&](int k) {
        const int* ids = unknowns.data() + static_cast<size_t>(k) * u;
        for (int j = 0; j < u; ++j) {
          const int q = ids[j];
          column[static_cast<size_t>(count)] = q;
          count += mark[static_cast<size_t>(q)] != p;
          mark[static_cast<size_t>(q)] = p;
        }
      };
      for (int at = incidenceStart_[p]; at < incidenceStart_[p + 1]; ++at) {
        // The element of an incidence k u + j, divided by a constant for the common sizes (a
        // division by the run-time u was a sixth of this loop).
        const int i = incidence_[at];
        const int k = u == 3 ? i / 3 : u == 4 ? i / 4 : i / u;
        addElement(k);
        if (!couplings) continue;
        for (int g = regularizer_.facetBegin(k); g < regularizer_.facetEnd(k); ++g)
          addElement(regularizer_.neighbour(g));
      }
      std::sort(column.begin(), column.begin() + count);
      inner.insert(inner.end(), column.begin(), column.begin() + count);
      outer[static_cast<size_t>(p) + 1] = static_cast<int>(inner.size());
    }
  });
  size_t nonZeros = 0;
  for (size_t c = 0, begin = 0; c < parts.size(); ++c, begin += static_cast<size_t>(grain)) {
    const size_t end = std::min(static_cast<size_t>(N), begin + static_cast<size_t>(grain));
    for (size_t p = begin; p < end; ++p) outer[p + 1] += static_cast<int>(nonZeros);
    nonZeros += parts[c].size();
  }
  A_ = SparseMatrix(N, N);
  A_.resizeNonZeros(static_cast<Eigen::Index>(nonZeros));
  std::copy(outer.begin(), outer.end(), A_.outerIndexPtr());
  int* inner = A_.innerIndexPtr();
  for (const std::vector<int>& part : parts) inner = std::copy(part.begin(), part.end(), inner);
  couplings_ = couplings;
}

void RegularizedSystem::assemble() const {
  const int r = model_.rows(), u = model_.localSize();
  std::fill(A_.valuePtr(), A_.valuePtr() + A_.nonZeros(), 0.0);
  // Elements: (1 - beta_k) a_k L_k^T L_k. Facets: ell beta_kl c_kl (L_k - L_l)^T (L_k - L_l),
  // none without the couplings in the pattern (every facet weight is 0 then).
  const Eigen::VectorXd& elementWeight = regularizer_.elementWeight();
  const Eigen::VectorXd& facetWeight = regularizer_.facetWeight();
  const std::vector<Facet> noFacets;
  const std::vector<Facet>& facets = couplings_ ? model_.discretization().facets() : noFacets;
  if (u == 3 && r == 2) {
    addElementBlocks<2, 3>(model_, elementWeight, r, u, A_);
    addFacetBlocks<2, 3>(model_, facets, facetWeight, r, u, A_);
  } else if (u == 3 && r == 3) {
    addElementBlocks<3, 3>(model_, elementWeight, r, u, A_);
    addFacetBlocks<3, 3>(model_, facets, facetWeight, r, u, A_);
  } else if (u == 4 && r == 3) {
    addElementBlocks<3, 4>(model_, elementWeight, r, u, A_);
    addFacetBlocks<3, 4>(model_, facets, facetWeight, r, u, A_);
  } else {
    addElementBlocks<0, 0>(model_, elementWeight, r, u, A_);
    addFacetBlocks<0, 0>(model_, facets, facetWeight, r, u, A_);
  }
  valuesDirty_ = false;
}

void RegularizedSystem::rightHandSide(const Stacked& t, Eigen::MatrixXd& b) const {
  applyC(t, nullptr, b);
}

void RegularizedSystem::restRightHandSide(Eigen::MatrixXd& b) const {
  const Eigen::MatrixXd& rest = model_.discretization().rest();
  if (!model_.iterative() || model_.coupled()) {
    // Fixed targets need no fits, and C t keeps planar ASAP's exact zeros; every coupled layout
    // is a linear energy's.
    Stacked t;
    model_.targets(rest, t);
    applyC(t, nullptr, b);
    return;
  }
  // A x_rest on the separable layout (the unknowns are the positions), about the centroid: A
  // annihilates translations, and the rounding then follows the mesh's size rather than its
  // distance from the origin. Read in place: a copy of the positions (24 MB at 1M vertices)
  // raised the 1M editor scenario's peak by 38 MB, as a freed block of that size lifts glibc's
  // mmap threshold and later blocks of its size stay in the heap.
  const SparseMatrix& A = matrix();
  // The centroid of the vertices the elements use: a vertex far away that none uses would
  // move it there and take the digits of every x - c.
  const std::vector<bool>& active = model_.discretization().active();
  const Eigen::Index used = std::count(active.begin(), active.end(), true);
  Eigen::RowVectorXd center = Eigen::RowVectorXd::Zero(rest.cols());
  if (used == rest.rows()) {
    center = rest.colwise().mean();
  } else if (used > 0) {
    for (Eigen::Index col = 0; col < rest.cols(); ++col) {
      double sum = 0.0;
      for (Eigen::Index v = 0; v < rest.rows(); ++v)
        if (active[static_cast<size_t>(v)]) sum += rest(v, col);
      center(col) = sum / static_cast<double>(used);
    }
  }
  b.setZero(A.rows(), rest.cols());
  for (Eigen::Index col = 0; col < rest.cols(); ++col)
    for (Eigen::Index j = 0; j < A.outerSize(); ++j) {
      const double x = rest(j, col) - center(col);
      for (SparseMatrix::InnerIterator it(A, j); it; ++it) b(it.row(), col) += it.value() * x;
    }
}

void RegularizedSystem::residualGradient(const Stacked& F, const Stacked& t, Eigen::MatrixXd& g) {
  applyC(t, &F, g);
  zeroFixed(g);
}

std::vector<std::vector<std::vector<int>>> RegularizedSystem::scatterGroups() const {
  const int m = model_.discretization().numElements();
  std::vector<std::vector<std::vector<int>>> colours(scatterStart_.size() - 1);
  for (size_t c = 0; c + 1 < scatterStart_.size(); ++c)
    for (int at = scatterStart_[c]; at < scatterStart_[c + 1]; ++at) {
      const int q = scatterOrder_[static_cast<size_t>(at)];
      std::vector<int>& group = colours[c].emplace_back();
      if (scatterGroup_ == 1) {
        group.push_back(q);
        continue;
      }
      for (int k = q * scatterGroup_; k < std::min(m, (q + 1) * scatterGroup_); ++k)
        group.push_back(k);
    }
  return colours;
}

void RegularizedSystem::applyC(const Stacked& t, const Stacked* F, Eigen::MatrixXd& b) const {
  const int r = model_.rows(), c = model_.columns(), u = model_.localSize();
  const int N = model_.numUnknowns();
  if (b.rows() != N || b.cols() != c) b.resize(N, c);
  b.setZero();
  // Colour by colour, each element adds its share L_k^T tau_k straight into b: no array of all
  // shares (m u c doubles, 137 MiB at two million faces, the 1M-vertex session's peak).
  const int m = model_.discretization().numElements();
  // Calls scatterShares for the elements `ids[0..count)` or, without ids, first .. first + count.
  const auto scatter = [&](const int* ids, int first, int count) {
    if (!model_.coupled() && r == 3 && u == 3)
      scatterShares<3, 3, 3>(model_, t, F, regularizer_, r, c, u, ids, first, count, b);
    else if (!model_.coupled() && r == 3 && u == 4)
      scatterShares<3, 3, 4>(model_, t, F, regularizer_, r, c, u, ids, first, count, b);
    else if (!model_.coupled() && r == 2 && u == 3)
      scatterShares<2, 2, 3>(model_, t, F, regularizer_, r, c, u, ids, first, count, b);
    else
      scatterShares<-1, -1, -1>(model_, t, F, regularizer_, r, c, u, ids, first, count, b);
  };
  for (size_t colour = 0; colour + 1 < scatterStart_.size(); ++colour) {
    const int* ids = scatterOrder_.data() + scatterStart_[colour];
    const int count = scatterStart_[colour + 1] - scatterStart_[colour];
    if (scatterGroup_ == 1) {
      parallel::forChunks(count, kColourGrain,
                          [&](int, int begin, int end) { scatter(ids + begin, 0, end - begin); });
      continue;
    }
    // Each group's elements in storage order, one after the other: their neighbours' blocks
    // are mostly the group's own, in cache.
    parallel::forChunks(count, 1, [&](int, int begin, int end) {
      for (int i = begin; i < end; ++i) {
        const int first = ids[i] * scatterGroup_;
        scatter(nullptr, first, std::min(m, first + scatterGroup_) - first);
      }
    });
  }
}

namespace {

// Affine rank of a point set (0 for one point, 1 for distinct collinear points, ...).
int affineRank(const Eigen::MatrixXd& P, double tolerance) {
  if (P.rows() <= 1) return 0;
  const Eigen::MatrixXd C = P.rowwise() - P.colwise().mean();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(C);
  int rank = 0;
  for (Eigen::Index i = 0; i < svd.singularValues().size(); ++i)
    if (svd.singularValues()(i) > tolerance) ++rank;
  return rank;
}

const char* needText(int rank) {
  switch (rank) {
    case 0:
      return "at least 1 handle vertex";
    case 1:
      return "2 distinct handle points";
    case 2:
      return "3 non-collinear handle points";
    default:
      return "4 non-coplanar handle points";
  }
}

}  // namespace

std::string RegularizedSystem::singularity() const {
  const Discretization& disc = model_.discretization();
  const int nc = disc.numComponents(), d = disc.dim();
  const auto& comp = disc.component();
  // What the energy alone pins: translations (1 point), 2D similarities or 2D infinitesimal
  // rotations (2 points), 3D infinitesimal rotations (3 non-collinear points).
  const int base = model_.energyModel().kernelRank(disc.kind());
  std::vector<bool> hasEnergy(nc, false);
  for (int k = 0; k < disc.numElements(); ++k)
    if (regularizer_.weights().element(k) < 1.0) hasEnergy[comp[disc.elements()(k, 0)]] = true;
  std::vector<std::vector<int>> handlesOf(nc);
  for (int v : handles_)
    if (comp[v] >= 0) handlesOf[comp[v]].push_back(v);
  std::vector<int> size(nc, 0), example(nc, -1);
  for (int v = 0; v < disc.numVertices(); ++v)
    if (comp[v] >= 0) {
      ++size[comp[v]];
      if (example[comp[v]] < 0) example[comp[v]] = v;
    }
  const double tolerance = 1e-8 * disc.boundingBoxDiagonal();
  for (int ci = 0; ci < nc; ++ci) {
    // beta = 1 on the whole component: S alone does not pin affine maps (docs/method.md, "The
    // regularizer").
    const int need = hasEnergy[ci] ? base : d;
    const auto& h = handlesOf[ci];
    if (static_cast<int>(h.size()) >= size[ci]) continue;  // every vertex held: nothing free
    Eigen::MatrixXd P(static_cast<Eigen::Index>(h.size()), d);
    for (size_t i = 0; i < h.size(); ++i)
      P.row(static_cast<Eigen::Index>(i)) = disc.rest().row(h[i]);
    if (!h.empty() && affineRank(P, tolerance) >= need) continue;
    return "deformation: mesh component " + std::to_string(ci) + " (" + std::to_string(size[ci]) +
           " vertices, including vertex " + std::to_string(example[ci]) + ") has " +
           std::to_string(h.size()) + " handle vertices; " + toString(model_.energy()) +
           (hasEnergy[ci] ? "" : " with beta = 1 on the whole component") + " needs " +
           needText(need);
  }
  return {};
}

Eigen::MatrixXd RegularizedSystem::solve(const Stacked& t, const Eigen::MatrixXd& handlePositions) {
  rightHandSide(t, b_);
  return solveRightHandSide(b_, handlePositions);
}

void RegularizedSystem::prepare() {
  const Discretization& disc = model_.discretization();
  const int q = model_.dofsPerVertex();
  if (partitionDirty_ || matrixDirty_) {
    const std::string reason = singularity();
    if (!reason.empty()) throw SingularSystem(reason);
  }
  if (partitionDirty_) {
    std::vector<bool> fixed(static_cast<size_t>(model_.numUnknowns()), false);
    for (int v = 0; v < disc.numVertices(); ++v)
      if (!disc.active()[v])
        for (int a = 0; a < q; ++a) fixed[static_cast<size_t>(v * q + a)] = true;
    for (int v : handles_)
      for (int a = 0; a < q; ++a) fixed[static_cast<size_t>(v * q + a)] = true;
    solver_.setPartition(Partition(fixed));
    partitionDirty_ = false;
    matrixDirty_ = true;
  }
  if (matrixDirty_) {
    if (valuesDirty_) assemble();
    try {
      solver_.setMatrix(A_, !patternChanged_);
      patternChanged_ = false;
    } catch (const NonFiniteSolution&) {
      throw;  // sliver elements: the caller names the thinnest
    } catch (const SingularSystem& e) {
      // E.g. lARAP on a flat surface leaves out-of-plane motion free to first order.
      throw SingularSystem(std::string("deformation: the ") + toString(model_.energy()) +
                           " system has no unique solution with these handles (" + e.what() + ")");
    }
    matrixDirty_ = false;
  }
}

Eigen::MatrixXd RegularizedSystem::applyInverse(const Eigen::MatrixXd& r) {
  prepare();
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(solver_.partition().numFixed(), r.cols());
  return solver_.solve(r, zero);
}

void RegularizedSystem::zeroFixed(Eigen::MatrixXd& x) {
  prepare();
  for (int id : solver_.partition().fixedIds()) x.row(id).setZero();
}

Eigen::MatrixXd RegularizedSystem::handleResponse(const Eigen::MatrixXd& v) {
  if (model_.coupled())
    throw InvalidParameter("deformation: handle responses need a separable energy layout");
  if (v.rows() != static_cast<Eigen::Index>(handles_.size()))
    throw InvalidParameter("deformation: handle values for " + std::to_string(v.rows()) +
                           " vertices, not " + std::to_string(handles_.size()));
  prepare();
  return solver_.solveFixedResponse(fixedValues(v, false));
}

Eigen::MatrixXd RegularizedSystem::fixedValues(const Eigen::MatrixXd& handleValues,
                                               bool restOffHandles) const {
  const Discretization& disc = model_.discretization();
  const int q = model_.dofsPerVertex();
  std::vector<int> handleOf(static_cast<size_t>(disc.numVertices()), -1);
  for (size_t i = 0; i < handles_.size(); ++i) handleOf[handles_[i]] = static_cast<int>(i);
  const Partition& part = solver_.partition();
  // Coupled layouts: one column, coordinate id % q of the vertex; separable: every column.
  const Eigen::Index c = q > 1 ? 1 : handleValues.cols();
  Eigen::MatrixXd xFixed(part.numFixed(), c);
  for (int i = 0; i < part.numFixed(); ++i) {
    const int id = part.fixedIds()[i], v = id / q;
    const int h = handleOf[static_cast<size_t>(v)];
    for (Eigen::Index col = 0; col < c; ++col) {
      const Eigen::Index a = q > 1 ? id % q : col;
      xFixed(i, col) = h >= 0 ? handleValues(h, a) : restOffHandles ? disc.rest()(v, a) : 0.0;
    }
  }
  return xFixed;
}

Eigen::MatrixXd RegularizedSystem::solveRightHandSide(const Eigen::MatrixXd& b,
                                                      const Eigen::MatrixXd& handlePositions) {
  prepare();
  // Fixed values: handle positions, rest positions of vertices without elements.
  Eigen::MatrixXd x = solver_.solve(b, fixedValues(handlePositions, true));
  if (!model_.coupled()) return x;  // the unknowns are the positions
  return model_.toPositions(x);
}

}  // namespace diffreg
