#include <diffreg/deformation/rotation.h>

namespace diffreg {

Matrix32 tangentPolarSvd(const Matrix32& M, double& trace) {
  const Eigen::JacobiSVD<Matrix32> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  trace = svd.singularValues().sum();
  return svd.matrixU().leftCols<2>() * svd.matrixV().transpose();
}

Eigen::Matrix3d closestRotation3(const Eigen::Matrix3d& C, double& trace) {
  Eigen::Vector3d sigma;
  const Eigen::Matrix3d R = closestRotation<3>(C, sigma);
  trace = sigma.sum();
  return R;
}

}  // namespace diffreg
