// The compiled library: the least-squares solver for double, instantiated once.
#include <sid/least_squares.hpp>

namespace sid::detail {
template LeastSquaresResult<double> solve_least_squares<double>(
    const char*, const ConstMatrixRef<double>&, const ConstVectorRef<double>&,
    const Eigen::Matrix<double, Eigen::Dynamic, 1>*, Eigen::Index, const LeastSquaresOptions&);
}  // namespace sid::detail
