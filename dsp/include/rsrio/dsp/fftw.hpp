// fftw3f helpers shared by everything in rsrio that makes FFT plans.
//
// FFTW's planner is not thread-safe: creating or destroying a plan while another thread does the
// same corrupts its global state. Every rsrio component takes fftw_planner_mutex() around plan
// creation and destruction (executing a plan is thread-safe and needs no lock). When the
// libfftw3f_threads library is available (Debian: libfftw3-dev ships it), the first use also calls
// fftwf_make_planner_thread_safe(), which protects code outside rsrio that plans too.
#pragma once

#include <complex>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string_view>

namespace rsrio {

/// The process-wide lock for FFTW's planner (plan creation and destruction).
std::mutex& fftw_planner_mutex();

/// Whether fftwf_make_planner_thread_safe() was available and has been called.
bool fftw_planner_made_thread_safe();

/// FFTW planning effort: "estimate" (FFTW_ESTIMATE: fast to plan, deterministic, the same plan in
/// every process, so replays reproduce bit for bit) or "measure" (FFTW_MEASURE: times candidate
/// algorithms at construction, may be a little faster per frame, may differ between runs).
unsigned fftw_planner_flags(std::string_view planning);

/// SIMD-aligned storage from fftwf_malloc, zero-initialised. Sized once; never reallocates.
template <typename T>
class AlignedBuffer {
 public:
  AlignedBuffer() = default;
  explicit AlignedBuffer(std::size_t n);
  T* data() { return ptr_.get(); }
  const T* data() const { return ptr_.get(); }
  std::size_t size() const { return size_; }
  T& operator[](std::size_t i) { return ptr_.get()[i]; }
  const T& operator[](std::size_t i) const { return ptr_.get()[i]; }

 private:
  struct Free {
    void operator()(T* p) const;
  };
  std::unique_ptr<T[], Free> ptr_;
  std::size_t size_ = 0;
};

extern template class AlignedBuffer<float>;
extern template class AlignedBuffer<std::complex<float>>;

/// A batched 1-D complex FFT plan (forward, unnormalised: X[k] = sum_n x[n] exp(-j 2 pi k n / N)):
/// `howmany` transforms of size `n`, transform i reading in[i * dist + k * stride] and writing
/// out[i * dist + k * stride]. Made under the planner lock; executable on other arrays of the same
/// layout and alignment (execute(in, out)).
class FftPlan {
 public:
  FftPlan() = default;
  FftPlan(int n, int howmany, int stride, int dist, std::complex<float>* in, std::complex<float>* out,
          unsigned flags);
  /// The general layout: input element k of transform i at in[i * idist + k * istride], output
  /// at out[i * odist + k * ostride] (e.g. a transform down the columns of a row-major block,
  /// written out transposed).
  FftPlan(int n, int howmany, std::complex<float>* in, int istride, int idist, std::complex<float>* out,
          int ostride, int odist, unsigned flags);
  ~FftPlan();
  FftPlan(FftPlan&& other) noexcept;
  FftPlan& operator=(FftPlan&& other) noexcept;
  FftPlan(const FftPlan&) = delete;
  FftPlan& operator=(const FftPlan&) = delete;

  /// Runs on the arrays the plan was made with.
  void execute() const;
  /// Runs on other arrays with the same layout and SIMD alignment as the planned ones.
  void execute(std::complex<float>* in, std::complex<float>* out) const;
  bool valid() const { return plan_ != nullptr; }

 private:
  void* plan_ = nullptr;  // fftwf_plan
};

}  // namespace rsrio
