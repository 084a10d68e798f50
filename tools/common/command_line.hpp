#pragma once
/// \file
/// The tools' one command-line parser: `--flag` and `--option VALUE` in any order (and, where a
/// tool accepts them, `--option=VALUE`). A bad argument stops the parse with a message naming the
/// option and the value; the tool prints it as "<program>: <message>" and exits with
/// kExitBadOption, as every calibd tool does for a bad option.

#include <cstddef>
#include <limits>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace calibd::tools {

inline constexpr int kExitBadOption = 2;

/// How many items a comma-separated list takes: [min, max].
struct Count {
  size_t min = 1;
  size_t max = std::numeric_limits<size_t>::max();
};

/// `text` split at its commas ("a,,b": "a", "", "b"; "": one empty item).
std::vector<std::string> SplitList(const std::string& text);

class CommandLine {
 public:
  /// argv as main() has it: argv[0], the program, is not an argument.
  CommandLine(std::string program, int argc, char** argv);
  /// The arguments after the program's name.
  CommandLine(std::string program, std::vector<std::string> args)
      : program_(std::move(program)), args_(std::move(args)) {}

  /// Also takes `--option=VALUE` for `--option VALUE` (an argument starting with "--" that holds
  /// a '='). A flag given a value that way is refused.
  void AcceptInlineValues() { inline_values_ = true; }

  /// Steps to the next argument; false after the last one or once an error was found.
  bool Next();
  /// The current argument (its name only, for `--option=VALUE`).
  const std::string& arg() const { return arg_; }
  bool Is(std::string_view name) const { return arg_ == name; }
  /// The current argument looks like an option ('-' and more), not like a positional argument.
  bool IsOption() const { return arg_.size() > 1 && arg_[0] == '-'; }

  /// The current option's value (the next argument, consumed, or the one after '='). Each returns
  /// false, with the error set, when the value is missing or not of its kind.
  bool Value(std::string* value);
  /// A value that is not empty.
  bool Text(std::string* value);
  /// `on` or `off`.
  bool OnOff(bool* value);
  /// An integer in [lo, hi]; `unit` (e.g. "ms"), if any, follows the range in the error.
  bool Integer(long lo, long hi, long* value, std::string_view unit = {});
  bool Integer(int lo, int hi, int* value, std::string_view unit = {});
  /// A number in [lo, hi]; `unit` as for Integer.
  bool Number(double lo, double hi, double* value, std::string_view unit = {});
  /// `count` comma-separated finite numbers (e.g. "1.2,0,1.95").
  bool Numbers(Count count, std::vector<double>* values);
  /// `count` comma-separated integers, each in [lo, hi] (e.g. "1,10").
  bool Integers(Count count, long lo, long hi, std::vector<long>* values);
  /// The current argument is no option of the tool's.
  void Unknown();
  /// An error of the tool's own (options that do not go together, a missing one).
  void Error(const std::string& message) { error_ = message; }

  bool failed() const { return !error_.empty(); }
  const std::string& error() const { return error_; }
  /// Prints "<program>: <the error>" to `err`; returns kExitBadOption.
  int Fail(std::ostream& err) const;

 private:
  // Sets the error "<option> must be <what> (got '<text>')"; returns false.
  bool Refuse(const std::string& what, const std::string& text);

  std::string program_;
  std::vector<std::string> args_;
  size_t next_ = 0;
  bool inline_values_ = false;
  bool has_inline_ = false;  // the current argument came as --option=VALUE
  bool inline_used_ = false;
  std::string arg_, inline_value_, error_;
};

}  // namespace calibd::tools
