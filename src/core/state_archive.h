// A flat binary archive for run states (a simulation's state file, controller States).
//
// A State lists its persistent fields once, in order:
//   template <class A> void serialize(A& a) { a(fsm); a(start_time); a(steps); }
// and StateWriter / StateReader walk that list. Supported fields: arithmetic values and enums,
// Eigen dense matrices (sizes stored), Eigen quaternions, std::array and std::vector of those or
// of trivially copyable structs, and std::string. The reader checks every size against what is
// left and throws StateFormatError on a mismatch, so a truncated or foreign file is an error,
// never a crash.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace stance {

class StateFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace detail {
template <class T>
struct is_std_vector : std::false_type {};
template <class T, class A>
struct is_std_vector<std::vector<T, A>> : std::true_type {};
template <class T>
struct is_std_array : std::false_type {};
template <class T, size_t N>
struct is_std_array<std::array<T, N>> : std::true_type {};
template <class T>
concept EigenDense = std::is_base_of_v<Eigen::DenseBase<T>, T>;
template <class T>
concept EigenQuaternion = std::is_base_of_v<Eigen::QuaternionBase<T>, T>;
}  // namespace detail

class StateWriter {
 public:
  explicit StateWriter(std::string& out) : out_(out) {}

  template <class T>
  void operator()(const T& value) {
    if constexpr (std::is_arithmetic_v<T> || std::is_enum_v<T>) {
      bytes(&value, sizeof(T));
    } else if constexpr (detail::EigenQuaternion<T>) {
      (*this)(value.coeffs());
    } else if constexpr (detail::EigenDense<T>) {
      size(value.rows());
      size(value.cols());
      for (Eigen::Index j = 0; j < value.cols(); ++j)
        for (Eigen::Index i = 0; i < value.rows(); ++i) (*this)(value(i, j));
    } else if constexpr (std::is_same_v<T, std::string>) {
      size(value.size());
      bytes(value.data(), value.size());
    } else if constexpr (detail::is_std_array<T>::value) {
      for (const auto& x : value) (*this)(x);
    } else if constexpr (detail::is_std_vector<T>::value) {
      size(value.size());
      for (const auto& x : value) (*this)(x);
    } else {
      static_assert(std::is_trivially_copyable_v<T>, "StateWriter: unsupported field type");
      bytes(&value, sizeof(T));
    }
  }

 private:
  void size(size_t n) {
    uint64_t v = n;
    bytes(&v, sizeof v);
  }
  void bytes(const void* p, size_t n) { out_.append(static_cast<const char*>(p), n); }
  std::string& out_;
};

class StateReader {
 public:
  StateReader(const std::string& in, size_t offset = 0) : in_(in), pos_(offset) {}

  template <class T>
  void operator()(T& value) {
    if constexpr (std::is_arithmetic_v<T> || std::is_enum_v<T>) {
      bytes(&value, sizeof(T));
    } else if constexpr (detail::EigenQuaternion<T>) {
      Eigen::Vector4d c;
      (*this)(c);
      value.coeffs() = c;
    } else if constexpr (detail::EigenDense<T>) {
      size_t rows = size(), cols = size();
      if (rows * cols * sizeof(typename T::Scalar) > left())
        throw StateFormatError("a matrix larger than the data left");
      if constexpr (T::RowsAtCompileTime != Eigen::Dynamic ||
                    T::ColsAtCompileTime != Eigen::Dynamic)
        if ((T::RowsAtCompileTime != Eigen::Dynamic && size_t(T::RowsAtCompileTime) != rows) ||
            (T::ColsAtCompileTime != Eigen::Dynamic && size_t(T::ColsAtCompileTime) != cols))
          throw StateFormatError("a fixed-size matrix of another size");
      value.resize(rows, cols);
      for (Eigen::Index j = 0; j < value.cols(); ++j)
        for (Eigen::Index i = 0; i < value.rows(); ++i) (*this)(value(i, j));
    } else if constexpr (std::is_same_v<T, std::string>) {
      size_t n = size();
      if (n > left()) throw StateFormatError("a string longer than the data left");
      value.assign(in_.data() + pos_, n);
      pos_ += n;
    } else if constexpr (detail::is_std_array<T>::value) {
      for (auto& x : value) (*this)(x);
    } else if constexpr (detail::is_std_vector<T>::value) {
      size_t n = size();
      if (n > left()) throw StateFormatError("a list longer than the data left");
      value.resize(n);
      for (auto& x : value) (*this)(x);
    } else {
      static_assert(std::is_trivially_copyable_v<T>, "StateReader: unsupported field type");
      bytes(&value, sizeof(T));
    }
  }

  size_t position() const { return pos_; }
  size_t left() const { return in_.size() - pos_; }

 private:
  size_t size() {
    uint64_t v = 0;
    bytes(&v, sizeof v);
    return static_cast<size_t>(v);
  }
  void bytes(void* p, size_t n) {
    if (n > left()) throw StateFormatError("truncated");
    std::memcpy(p, in_.data() + pos_, n);
    pos_ += n;
  }
  const std::string& in_;
  size_t pos_;
};

}  // namespace stance
