#pragma once
// Line handling shared by the LAMMPS data and dump readers (internal to core/io).
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace polydem::io::lammps {

/// The lines of a text file with their numbers (1-based); CR LF accepted. Throws InputError if unreadable.
struct Lines {
  std::filesystem::path file;
  std::vector<std::string> text;

  explicit Lines(const std::filesystem::path& path);
  /// InputError "FILE:LINE: problem" (line 0: the file as a whole).
  [[noreturn]] void fail(std::size_t line, std::string_view problem) const;
};

/// Blank-separated words of `line` up to a '#'.
std::vector<std::string_view> words(std::string_view line);

/// `word` as a finite double, or an InputError naming `what`.
double number(const Lines& lines, std::size_t line, std::string_view word, std::string_view what);

/// `word` as an integer (no fraction, no trailing characters), or an InputError naming `what`.
long long integer(const Lines& lines, std::size_t line, std::string_view word, std::string_view what);

}  // namespace polydem::io::lammps
