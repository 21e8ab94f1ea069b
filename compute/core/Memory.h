// Explicit memory of one executor's device. Buffers are RAII, sized at run time, with byte accounting.
// No implicit host mirror: host copies are explicit (ParticleSnapshot).
#pragma once
#include <cstddef>
#include <cstring>
#include <memory>
#include <vector>
#include <stdexcept>
#include <utility>

namespace pflow::compute {

// Where a Buffer lives. The CPU executor's is host memory; the CUDA executor's is cudaMalloc'd.
// A device allocation that did not fit (the message gives the sizes). The step loop reports it as
// RESOURCE_EXHAUSTED; any other exception from a device is an internal error.
class OutOfDeviceMemory : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class MemorySpace {
 public:
  virtual ~MemorySpace() = default;
  virtual void* allocate(std::size_t bytes) = 0;
  virtual void deallocate(void* p) = 0;
  virtual void copyToHost(void* hostDst, const void* src, std::size_t bytes) = 0;
  virtual void copyFromHost(void* dst, const void* hostSrc, std::size_t bytes) = 0;
  virtual void copyWithin(void* dst, const void* src, std::size_t bytes) = 0;
  virtual void fillBytes(void* dst, unsigned char value, std::size_t bytes) = 0;
  // Whether a block that grows keeping its contents waits in host memory while it is reallocated
  // (Buffer::growKeep): a device's memory is the scarce one, so there the old and the grown block are never held
  // together; the host's keeps both for the copy.
  virtual bool growsThroughHost() const { return false; }
  std::size_t bytesInUse() const { return m_bytesInUse; }
  std::size_t peakBytes() const { return m_peakBytes; }

 protected:
  void account(std::ptrdiff_t delta) {
    m_bytesInUse = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(m_bytesInUse) + delta);
    if (m_bytesInUse > m_peakBytes) m_peakBytes = m_bytesInUse;
  }

 private:
  std::size_t m_bytesInUse = 0;
  std::size_t m_peakBytes = 0;
};

// Host memory, 64-byte aligned. Large blocks are first touched, copied and filled by `threads` OpenMP
// threads in equal contiguous shares, the way the executor's static loops later walk them: each page
// then lives on the NUMA node of the core that works on it (the kernel places a page where it is first
// written). PFLOW_FIRST_TOUCH=0 turns the parallel first touch off (for measurements).
class HostMemory final : public MemorySpace {
 public:
  explicit HostMemory(int threads = 1);
  void* allocate(std::size_t bytes) override;
  void deallocate(void* p) override;
  void copyToHost(void* d, const void* s, std::size_t b) override { copy(d, s, b); }
  void copyFromHost(void* d, const void* s, std::size_t b) override { copy(d, s, b); }
  void copyWithin(void* d, const void* s, std::size_t b) override { copy(d, s, b); }
  void fillBytes(void* d, unsigned char v, std::size_t b) override;

 private:
  void copy(void* d, const void* s, std::size_t b) const;
  int m_threads;
  bool m_firstTouch;
};

// An untyped, owning buffer in one MemorySpace.
class Buffer {
 public:
  Buffer() = default;
  Buffer(MemorySpace& space, std::size_t bytes) : m_space(&space) { resize(bytes); }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  Buffer(Buffer&& o) noexcept { swap(o); }
  Buffer& operator=(Buffer&& o) noexcept { swap(o); return *this; }
  ~Buffer() { release(); }

  void bind(MemorySpace& space) { m_space = &space; }
  // Reallocates (contents are not kept) when the size changes.
  void resize(std::size_t bytes) {
    if (bytes == m_bytes) return;
    release();
    if (bytes) m_ptr = m_space->allocate(bytes);
    m_bytes = bytes;
  }
  // Grows to at least `bytes`, keeping the first min(old, new) bytes: growPlaced with the old contents in place.
  void growKeep(std::size_t bytes) {
    if (bytes <= m_bytes) return;
    growPlaced(bytes, {Move{0, 0, m_bytes}});
  }
  // A piece of the old contents that growPlaced keeps: `bytes` from offset `from` of the old block to offset `to` of
  // the grown one.
  struct Move {
    std::size_t from, to, bytes;
  };
  // Grows to `bytes` (more than now), the pieces `moves` of the old contents kept at their new offsets, the rest
  // undefined. In a space that grows through the host (a GPU's), the pieces wait in host memory while the old block is
  // released and the larger one allocated, so that growing never holds both (a contact-slot field growing by one
  // slot, or every field of a rank whose rows outgrow their capacity, would otherwise lift a run's peak by the old
  // block); if the larger block cannot be had, the old size is allocated again and the pieces put back where they
  // were before the error goes on. Elsewhere the larger block is allocated beside the old one.
  void growPlaced(std::size_t bytes, const std::vector<Move>& moves) {
    if (!m_bytes || !m_space->growsThroughHost()) {
      Buffer bigger(*m_space, bytes);
      for (const Move& m : moves)
        if (m.bytes) m_space->copyWithin(static_cast<unsigned char*>(bigger.m_ptr) + m.to, static_cast<unsigned char*>(m_ptr) + m.from, m.bytes);
      swap(bigger);
      return;
    }
    std::size_t kept = 0;
    for (const Move& m : moves) kept += m.bytes;
    std::unique_ptr<unsigned char[]> host(new unsigned char[kept ? kept : 1]);
    const auto each = [&](auto&& f) {
      std::size_t at = 0;
      for (const Move& m : moves) {
        if (m.bytes) f(m, host.get() + at);
        at += m.bytes;
      }
    };
    each([&](const Move& m, unsigned char* h) { m_space->copyToHost(h, static_cast<unsigned char*>(m_ptr) + m.from, m.bytes); });
    const std::size_t old = m_bytes;
    release();
    try {
      m_ptr = m_space->allocate(bytes);
      m_bytes = bytes;
    } catch (...) {
      m_ptr = m_space->allocate(old);
      m_bytes = old;
      each([&](const Move& m, const unsigned char* h) { m_space->copyFromHost(static_cast<unsigned char*>(m_ptr) + m.from, h, m.bytes); });
      throw;
    }
    each([&](const Move& m, const unsigned char* h) { m_space->copyFromHost(static_cast<unsigned char*>(m_ptr) + m.to, h, m.bytes); });
  }
  void swap(Buffer& o) noexcept {
    std::swap(m_space, o.m_space);
    std::swap(m_ptr, o.m_ptr);
    std::swap(m_bytes, o.m_bytes);
  }
  void* data() { return m_ptr; }
  const void* data() const { return m_ptr; }
  template <class T> T* as() { return static_cast<T*>(m_ptr); }
  template <class T> const T* as() const { return static_cast<const T*>(m_ptr); }
  std::size_t bytes() const { return m_bytes; }
  MemorySpace* space() const { return m_space; }

 private:
  void release() {
    if (m_ptr) m_space->deallocate(m_ptr);
    m_ptr = nullptr;
    m_bytes = 0;
  }
  MemorySpace* m_space = nullptr;
  void* m_ptr = nullptr;
  std::size_t m_bytes = 0;
};

}  // namespace pflow::compute
