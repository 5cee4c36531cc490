#include "core/obj_writer.hpp"

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "core/input_error.hpp"

namespace twill {

void write_obj(const std::string& path, const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  if (V.cols() != 3 && V.rows() > 0)
    throw std::invalid_argument("write_obj: V must have 3 columns, has " +
                                std::to_string(V.cols()));
  if (F.cols() != 3 && F.rows() > 0)
    throw std::invalid_argument("write_obj: F must have 3 columns, has " +
                                std::to_string(F.cols()));
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= V.rows()))
    throw std::invalid_argument("write_obj: face index out of range [0, " +
                                std::to_string(V.rows()) + ")");
  // C stdio: "%.17g" is the shortest format guaranteed to round-trip every double, without
  // depending on iostream locale or precision state.
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!file) throw InputError({path, 0, ""}, "cannot open the OBJ file for writing");
  std::fprintf(file.get(), "# twill surface: %ld vertices, %ld faces\n",
               static_cast<long>(V.rows()), static_cast<long>(F.rows()));
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    std::fprintf(file.get(), "v %.17g %.17g %.17g\n", V(i, 0), V(i, 1), V(i, 2));
  for (Eigen::Index i = 0; i < F.rows(); ++i)
    std::fprintf(file.get(), "f %d %d %d\n", F(i, 0) + 1, F(i, 1) + 1, F(i, 2) + 1);
  if (std::ferror(file.get()) || std::fflush(file.get()) != 0)
    throw InputError({path, 0, ""}, "writing the OBJ file failed");
}

}  // namespace twill
