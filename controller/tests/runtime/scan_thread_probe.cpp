// Replacement global allocation functions and mutex-lock interposers for the runtime test
// binary; see scan_thread_probe.hpp.
#include "scan_thread_probe.hpp"

#include <dlfcn.h>
#include <pthread.h>

#include <atomic>
#include <cstdlib>
#include <new>

namespace {

std::atomic<std::uint64_t> g_allocations{0};
std::atomic<std::uint64_t> g_deallocations{0};
std::atomic<std::uint64_t> g_mutex_locks{0};
// Constant-initialised, so reading it needs no TLS initialisation (which could allocate).
thread_local bool t_armed = false;

void* counted_malloc(std::size_t size) noexcept {
  if (t_armed) g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(size == 0 ? 1 : size);
}

void* counted_aligned_malloc(std::size_t size, std::align_val_t alignment) noexcept {
  if (t_armed) g_allocations.fetch_add(1, std::memory_order_relaxed);
  const auto align = static_cast<std::size_t>(alignment);
  void* memory = nullptr;
  if (posix_memalign(&memory, align < sizeof(void*) ? sizeof(void*) : align,
                     size == 0 ? 1 : size) != 0) {
    return nullptr;
  }
  return memory;
}

void counted_free(void* memory) noexcept {
  if (memory == nullptr) return;
  if (t_armed) g_deallocations.fetch_add(1, std::memory_order_relaxed);
  std::free(memory);
}

void* throwing_malloc(std::size_t size) {
  void* memory = counted_malloc(size);
  if (memory == nullptr) throw std::bad_alloc();
  return memory;
}

void* throwing_aligned_malloc(std::size_t size, std::align_val_t alignment) {
  void* memory = counted_aligned_malloc(size, alignment);
  if (memory == nullptr) throw std::bad_alloc();
  return memory;
}

using MutexFunction = int (*)(pthread_mutex_t*);

MutexFunction next_symbol(std::atomic<MutexFunction>& cache, const char* name) noexcept {
  MutexFunction function = cache.load(std::memory_order_acquire);
  if (function == nullptr) {
    function = reinterpret_cast<MutexFunction>(dlsym(RTLD_NEXT, name));
    cache.store(function, std::memory_order_release);
  }
  return function;
}

std::atomic<MutexFunction> g_next_lock{nullptr};
std::atomic<MutexFunction> g_next_trylock{nullptr};

}  // namespace

namespace fl::test {

ProbeCounts probe_counts() {
  return ProbeCounts{g_allocations.load(), g_deallocations.load(), g_mutex_locks.load()};
}

void reset_probe_counts() {
  g_allocations.store(0);
  g_deallocations.store(0);
  g_mutex_locks.store(0);
}

void arm_probe_on_this_thread(bool armed) { t_armed = armed; }

}  // namespace fl::test

// std::mutex, std::condition_variable and spdlog's sinks all end in these two.
extern "C" int pthread_mutex_lock(pthread_mutex_t* mutex) {
  if (t_armed) g_mutex_locks.fetch_add(1, std::memory_order_relaxed);
  return next_symbol(g_next_lock, "pthread_mutex_lock")(mutex);
}

extern "C" int pthread_mutex_trylock(pthread_mutex_t* mutex) {
  if (t_armed) g_mutex_locks.fetch_add(1, std::memory_order_relaxed);
  return next_symbol(g_next_trylock, "pthread_mutex_trylock")(mutex);
}

void* operator new(std::size_t size) { return throwing_malloc(size); }
void* operator new[](std::size_t size) { return throwing_malloc(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return counted_malloc(size);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return counted_malloc(size);
}
void* operator new(std::size_t size, std::align_val_t alignment) {
  return throwing_aligned_malloc(size, alignment);
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return throwing_aligned_malloc(size, alignment);
}
void* operator new(std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return counted_aligned_malloc(size, alignment);
}
void* operator new[](std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return counted_aligned_malloc(size, alignment);
}

void operator delete(void* memory) noexcept { counted_free(memory); }
void operator delete[](void* memory) noexcept { counted_free(memory); }
void operator delete(void* memory, std::size_t) noexcept { counted_free(memory); }
void operator delete[](void* memory, std::size_t) noexcept { counted_free(memory); }
void operator delete(void* memory, const std::nothrow_t&) noexcept { counted_free(memory); }
void operator delete[](void* memory, const std::nothrow_t&) noexcept { counted_free(memory); }
void operator delete(void* memory, std::align_val_t) noexcept { counted_free(memory); }
void operator delete[](void* memory, std::align_val_t) noexcept { counted_free(memory); }
void operator delete(void* memory, std::size_t, std::align_val_t) noexcept { counted_free(memory); }
void operator delete[](void* memory, std::size_t, std::align_val_t) noexcept {
  counted_free(memory);
}
void operator delete(void* memory, std::align_val_t, const std::nothrow_t&) noexcept {
  counted_free(memory);
}
void operator delete[](void* memory, std::align_val_t, const std::nothrow_t&) noexcept {
  counted_free(memory);
}
