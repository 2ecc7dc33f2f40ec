// Error values for bad data and I/O.
//
// Sawyer reports problems with input in three tiers (docs/style.md 7): programmer mistakes assert,
// bad data or I/O returns an Error that says where (file, key, slice, knot), and only main()
// turns an Error into a message and an exit code. Nothing below apps/ throws across a library
// boundary or calls exit().
//
//   Result<LogModel> r = read_log_json(path);
//   if (!r) { std::cerr << r.error().message() << "\n"; return 1; }
//   const LogModel& log = r.value();
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace sawyer {

// One clear line: "<where>: <what is wrong>".
class Error {
 public:
  Error() = default;
  explicit Error(std::string message) : message_(std::move(message)) {}
  Error(const std::string& where, const std::string& what)
      : message_(where.empty() ? what : where + ": " + what) {}

  const std::string& message() const { return message_; }

  // Returns a copy with `where` put in front, e.g. the file name around a key error.
  Error with_context(const std::string& where) const { return Error(where, message_); }

 private:
  std::string message_;
};

// A value or an Error. Accessing the wrong alternative is a programmer error (asserts).
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & {
    assert(ok());
    return std::get<0>(v_);
  }
  const T& value() const& {
    assert(ok());
    return std::get<0>(v_);
  }
  T&& value() && {
    assert(ok());
    return std::get<0>(std::move(v_));
  }
  const Error& error() const {
    assert(!ok());
    return std::get<1>(v_);
  }

 private:
  std::variant<T, Error> v_;
};

// Success or an Error, for operations with no value.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT
  static Status Ok() { return Status(); }

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const {
    assert(!ok_);
    return error_;
  }

 private:
  Error error_;
  bool ok_ = true;
};

}  // namespace sawyer
