#pragma once
// The running median of the last five values added: the predictor of X and Y differences in
// LAZ's POINT10 and POINT14 codecs.
#include <array>
#include <cstdint>

namespace pointfair::io::laz {

/// The median of the last five values added (a running five-value window).
class Median5 {
 public:
  void reset() {
    v_.fill(0);
    high_ = true;
  }
  std::int32_t get() const { return v_[2]; }
  void add(std::int32_t x) {
    auto& v = v_;
    if (high_) {
      if (x < v[2]) {
        v[4] = v[3];
        v[3] = v[2];
        if (x < v[0]) {
          v[2] = v[1];
          v[1] = v[0];
          v[0] = x;
        } else if (x < v[1]) {
          v[2] = v[1];
          v[1] = x;
        } else {
          v[2] = x;
        }
      } else {
        if (x < v[3]) {
          v[4] = v[3];
          v[3] = x;
        } else {
          v[4] = x;
        }
        high_ = false;
      }
    } else {
      if (v[2] < x) {
        v[0] = v[1];
        v[1] = v[2];
        if (v[4] < x) {
          v[2] = v[3];
          v[3] = v[4];
          v[4] = x;
        } else if (v[3] < x) {
          v[2] = v[3];
          v[3] = x;
        } else {
          v[2] = x;
        }
      } else {
        if (v[1] < x) {
          v[0] = v[1];
          v[1] = x;
        } else {
          v[0] = x;
        }
        high_ = true;
      }
    }
  }

 private:
  std::array<std::int32_t, 5> v_{};
  bool high_ = true;
};

}  // namespace pointfair::io::laz
