#include "rsrio/dsp/fftw.hpp"

#include <fftw3.h>

#include <cstring>
#include <stdexcept>
#include <string>

namespace rsrio {

namespace {
bool g_thread_safe = false;
}

std::mutex& fftw_planner_mutex() {
  static std::mutex m;
  static std::once_flag once;
  std::call_once(once, [] {
#ifdef RSRIO_HAVE_FFTW3F_THREADS
    fftwf_make_planner_thread_safe();
    g_thread_safe = true;
#endif
  });
  return m;
}

bool fftw_planner_made_thread_safe() {
  (void)fftw_planner_mutex();
  return g_thread_safe;
}

unsigned fftw_planner_flags(std::string_view planning) {
  if (planning == "estimate") return FFTW_ESTIMATE;
  if (planning == "measure") return FFTW_MEASURE;
  throw std::invalid_argument("FFT planning must be 'estimate' or 'measure', got '" + std::string(planning) +
                              "'");
}

template <typename T>
AlignedBuffer<T>::AlignedBuffer(std::size_t n) : size_(n) {
  if (n == 0) return;
  void* p = fftwf_malloc(n * sizeof(T));
  if (!p) throw std::bad_alloc();
  std::memset(p, 0, n * sizeof(T));
  ptr_.reset(static_cast<T*>(p));
}

template <typename T>
void AlignedBuffer<T>::Free::operator()(T* p) const {
  fftwf_free(p);
}

template class AlignedBuffer<float>;
template class AlignedBuffer<std::complex<float>>;

FftPlan::FftPlan(int n, int howmany, int stride, int dist, std::complex<float>* in, std::complex<float>* out,
                 unsigned flags)
    : FftPlan(n, howmany, in, stride, dist, out, stride, dist, flags) {}

FftPlan::FftPlan(int n, int howmany, std::complex<float>* in, int istride, int idist,
                 std::complex<float>* out, int ostride, int odist, unsigned flags) {
  std::lock_guard<std::mutex> lock(fftw_planner_mutex());
  int dims[1] = {n};
  plan_ = fftwf_plan_many_dft(1, dims, howmany, reinterpret_cast<fftwf_complex*>(in), nullptr, istride, idist,
                              reinterpret_cast<fftwf_complex*>(out), nullptr, ostride, odist, FFTW_FORWARD,
                              flags);
  if (!plan_)
    throw std::runtime_error("fftwf_plan_many_dft failed (n " + std::to_string(n) + ", howmany " +
                             std::to_string(howmany) + ")");
}

FftPlan::~FftPlan() {
  if (plan_) {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    fftwf_destroy_plan(static_cast<fftwf_plan>(plan_));
  }
}

FftPlan::FftPlan(FftPlan&& other) noexcept : plan_(other.plan_) {
  other.plan_ = nullptr;
}

FftPlan& FftPlan::operator=(FftPlan&& other) noexcept {
  if (this != &other) {
    if (plan_) {
      std::lock_guard<std::mutex> lock(fftw_planner_mutex());
      fftwf_destroy_plan(static_cast<fftwf_plan>(plan_));
    }
    plan_ = other.plan_;
    other.plan_ = nullptr;
  }
  return *this;
}

void FftPlan::execute() const {
  fftwf_execute(static_cast<fftwf_plan>(plan_));
}

void FftPlan::execute(std::complex<float>* in, std::complex<float>* out) const {
  fftwf_execute_dft(static_cast<fftwf_plan>(plan_), reinterpret_cast<fftwf_complex*>(in),
                    reinterpret_cast<fftwf_complex*>(out));
}

}  // namespace rsrio
