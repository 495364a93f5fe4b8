#pragma once
// How a host refuses a request: a kind the asker can act on and a message naming the problem. The
// kinds are the contract's own, not a transport's: the HTTP layer (control/) maps them to status
// codes, a test or another transport reads them as they are.

#include <cassert>
#include <optional>
#include <string>
#include <utility>
#include <variant>

namespace doppel::contract {

enum class ErrorKind {
  kInvalid,      // a value of the request is wrong (the message names the field)
  kNotFound,     // no such robot, camera, sensor, fault, ...
  kConflict,     // not possible now (a paused simulation needed, a replay cannot change the world, ...)
  kUnavailable,  // the host did not answer in time, or has nothing to give yet; asking again may work
};

struct Error {
  ErrorKind kind = ErrorKind::kInvalid;
  std::string message;
};

// The answer to a request that returns nothing: done, or an Error.
class [[nodiscard]] Outcome {
 public:
  Outcome() = default;
  Outcome(Error error) : error_(std::move(error)) {}  // NOLINT(google-explicit-constructor): return Error{...}
  static Outcome done() { return {}; }
  static Outcome fail(ErrorKind kind, std::string message) { return Error{kind, std::move(message)}; }

  bool ok() const noexcept { return !error_.has_value(); }
  const Error& error() const {
    assert(error_);
    return *error_;
  }

 private:
  std::optional<Error> error_;
};

// The answer to a request that returns a value: the value, or an Error.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
  Result(Error error) : value_(std::move(error)) {}  // NOLINT(google-explicit-constructor)
  static Result fail(ErrorKind kind, std::string message) { return Error{kind, std::move(message)}; }

  bool ok() const noexcept { return std::holds_alternative<T>(value_); }
  const T& value() const { return std::get<T>(value_); }
  T& value() { return std::get<T>(value_); }
  const Error& error() const { return std::get<Error>(value_); }

 private:
  std::variant<T, Error> value_;
};

}  // namespace doppel::contract
