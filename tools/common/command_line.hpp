#pragma once
/// \file
/// The offline tools' command lines: `--flag` and `--option VALUE` in any order. A bad argument
/// stops the parse with a message naming it; the tool prints it as "<program>: <message>" and
/// exits with kExitBadOption, as every calibd tool does for a bad option.

#include <ostream>
#include <string>
#include <string_view>

namespace calibd::tools {

inline constexpr int kExitBadOption = 2;

class CommandLine {
 public:
  CommandLine(std::string program, int argc, char** argv)
      : program_(std::move(program)), argc_(argc), argv_(argv) {}

  /// Steps to the next argument; false after the last one or once an error was found.
  bool Next();
  const std::string& arg() const { return arg_; }
  bool Is(std::string_view name) const { return arg_ == name; }

  /// The current option's value (the next argument, consumed). Each returns false, with the
  /// error set, when the value is missing or not of its kind.
  bool Value(std::string* value);
  /// `on` or `off`.
  bool OnOff(bool* value);
  /// An integer in [lo, hi].
  bool Integer(long lo, long hi, long* value);
  /// A number in [lo, hi].
  bool Number(double lo, double hi, double* value);
  /// The current argument is no option of the tool's.
  void Unknown();
  /// An error of the tool's own (options that do not go together, a missing one).
  void Error(const std::string& message) { error_ = message; }

  bool failed() const { return !error_.empty(); }
  const std::string& error() const { return error_; }
  /// Prints "<program>: <the error>" to `err`; returns kExitBadOption.
  int Fail(std::ostream& err) const;

 private:
  std::string program_;
  int argc_;
  char** argv_;
  int next_ = 1;
  std::string arg_, error_;
};

}  // namespace calibd::tools
