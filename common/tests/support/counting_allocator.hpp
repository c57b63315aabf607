#pragma once
// A counting global operator new for "allocates nothing" tests: link the object library
// rsrio_counting_allocator into the test, and every new / new[] (aligned or not) made anywhere in
// the process is counted. The replacements live in counting_allocator.cpp, linked as objects so
// that they replace the standard library's operators in the whole executable.

namespace rsrio::testing {

/// Calls of the global operator new and new[] so far, on all threads.
long allocation_count() noexcept;

/// One new-expression whose result escapes (the compiler may not elide it): allocation_count()
/// must go up by exactly one, or the replacement operators are not this executable's.
void allocate_once();

}  // namespace rsrio::testing
