#include "fitting/fit_output_folder.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <vector>

#include "core/input_error.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

/// Longest sanitised name (bytes): keeps `fit-<name>.incomplete` far below NAME_MAX (255).
constexpr std::size_t kMaxComponentBytes = 64;

bool has_marker(const fs::path& dir, const OutputFolderKind& kind) {
  std::error_code ec;
  return fs::is_regular_file(fs::symlink_status(dir / kind.marker, ec));
}

bool is_empty_folder(const fs::path& dir) {
  std::error_code ec;
  return fs::is_empty(dir, ec) && !ec;
}

// Removes twill's own files from a folder with the marker (the marker last), then the folder
// itself if that left it empty. Anything else in it stays.
void remove_own_files(const fs::path& dir, const OutputFolderKind& kind) {
  if (!has_marker(dir, kind)) return;
  std::vector<fs::path> remove;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name == kind.marker || !kind.owns(name)) continue;
    if (e.is_symlink() || e.is_regular_file()) remove.push_back(e.path());  // a symlink goes, not its target
  }
  for (const fs::path& p : remove) fs::remove(p);
  fs::remove(dir / kind.marker);
  std::error_code ec;
  if (is_empty_folder(dir)) fs::remove(dir, ec);
}

void write_marker(const fs::path& dir, const OutputFolderKind& kind) {
  std::ofstream out(dir / kind.marker);
  out << "This folder was written by `" << kind.command << "`. twill replaces only its own files here:\n"
      << kind.files;
  if (!out.flush()) throw std::runtime_error("cannot write " + (dir / kind.marker).string());
}

std::string listed(const std::set<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += "  " + name + "\n";
  return text;
}

}  // namespace

const std::set<std::string>& fit_output_file_names() {
  static const std::set<std::string> names = {
      "params.yaml", "config.yaml", "report.json", "report.md", "fig2_force_elongation.png",
      "fig3_error_vs_degree.png", "fig4_validation_error.png", "report-incomplete.json",
      "report-incomplete.md", "error.txt", kFitMarkerFile};
  return names;
}

const OutputFolderKind& fit_output_kind() {
  static const OutputFolderKind kind = {"twill fit", kFitMarkerFile, listed(fit_output_file_names()), "dataset",
                                        [](const std::string& name) { return fit_output_file_names().count(name) > 0; }};
  return kind;
}

std::string safe_path_component(const std::string& name) {
  std::string out;
  bool gap = false;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    const bool keep = (u >= 'a' && u <= 'z') || (u >= 'A' && u <= 'Z') || (u >= '0' && u <= '9') || c == '.' ||
                      c == '-' || c == '_';
    if (!keep) {
      gap = true;
      continue;
    }
    if (gap && !out.empty()) out += '_';
    gap = false;
    out += c;
  }
  auto trim = [](std::string& s) {
    while (!s.empty() && (s.front() == '.' || s.front() == '_')) s.erase(0, 1);
    while (!s.empty() && (s.back() == '.' || s.back() == '_')) s.pop_back();
  };
  trim(out);
  if (out.size() > kMaxComponentBytes) out.resize(kMaxComponentBytes);
  trim(out);
  return out.empty() ? "dataset" : out;
}

std::filesystem::path default_fit_folder(const std::string& dataset_name) {
  return fs::path("out") / ("fit-" + safe_path_component(dataset_name));
}

OutputFolder::OutputFolder(const OutputFolderKind& kind, fs::path out, const std::string& source_folder, bool force,
                           const std::string& option)
    : kind_(kind), out_(std::move(out)) {
  auto fail = [&](const std::string& what) {
    throw InputError({"command line", 0, option}, "output folder " + out_.string() + ": " + what);
  };
  if (out_.empty()) fail("an empty path");
  if (out_.filename().empty() || out_.filename() == "." || out_.filename() == "..")
    out_ = fs::absolute(out_).lexically_normal();  // "dir/", ".", "..": name the folder itself
  if (out_.filename().empty()) out_ = out_.parent_path();
  if (out_ == out_.root_path()) fail("the root folder is never an output folder");
  std::error_code ec;
  if (!source_folder.empty()) {
    const fs::path source = fs::weakly_canonical(source_folder, ec);
    if (!ec && fs::weakly_canonical(out_, ec) == source && !ec)
      fail("is the " + kind_.source + " folder; " + kind_.command + " never writes into it (choose another -o)");
  }
  const fs::file_status status = fs::status(out_, ec);
  const bool exists = fs::exists(fs::symlink_status(out_, ec));
  if (exists) {
    if (!fs::is_directory(status))
      fail("exists and is not a folder; twill never replaces a file (choose another -o)");
    if (fs::exists(out_ / "fabric.yaml"))
      fail("holds a fabric.yaml: it is a dataset folder, never an output folder (choose another -o)");
    out_was_ours_ = has_marker(out_, kind_);
    if (!out_was_ours_ && !is_empty_folder(out_) && !force)
      fail("exists, is not empty and is not a twill output (no " + kind_.marker +
           " marker); choose another -o, or pass --force to write twill's files into it (nothing else in it is "
           "touched)");
    if (access(out_.c_str(), W_OK | X_OK) != 0) fail(std::string("not writable: ") + std::strerror(errno));
  }
  const fs::path parent = fs::absolute(out_).parent_path();
  fs::create_directories(parent, ec);
  if (ec) fail("cannot create its parent folder " + parent.string() + ": " + ec.message());
  if (access(parent.c_str(), W_OK | X_OK) != 0)
    fail("its parent folder " + parent.string() + " is not writable: " + std::strerror(errno));

  staging_ = out_.string() + ".partial";
  if (fs::exists(fs::symlink_status(staging_, ec))) {
    // A leftover of an interrupted fit is twill's (it has the marker) and goes; anything else
    // with that name is the user's.
    if (!fs::is_directory(fs::symlink_status(staging_, ec)) || !has_marker(staging_, kind_))
      fail(staging_.string() + " exists and is not twill's staging folder; move it away");
    remove_own_files(staging_, kind_);
    if (fs::exists(staging_))
      fail(staging_.string() + " holds files twill did not write; move them away");
  }
  if (!fs::create_directory(staging_, ec) || ec)
    fail("cannot create the staging folder " + staging_.string() + ": " + (ec ? ec.message() : "exists"));
  write_marker(staging_, kind_);
}

OutputFolder::~OutputFolder() {
  if (done_) return;
  try {
    remove_own_files(staging_, kind_);
  } catch (...) {
    // Best effort in a destructor: a leftover staging folder is reported by the next run.
  }
}

void OutputFolder::commit() {
  std::error_code ec;
  if (out_was_ours_) remove_own_files(out_, kind_);
  if (!fs::exists(out_) || is_empty_folder(out_)) {
    fs::rename(staging_, out_);  // replaces an empty folder atomically (rename(2))
    done_ = true;
    return;
  }
  // OUTDIR keeps files that are not twill's: move each output in, the marker last.
  for (const fs::directory_entry& e : fs::directory_iterator(staging_))
    if (e.path().filename() != kind_.marker) fs::rename(e.path(), out_ / e.path().filename());
  fs::rename(staging_ / kind_.marker, out_ / kind_.marker);
  fs::remove(staging_);
  done_ = true;
}

std::optional<fs::path> OutputFolder::keep_incomplete() {
  const fs::path kept = out_.string() + ".incomplete";
  std::error_code ec;
  if (fs::exists(fs::symlink_status(kept, ec))) {
    if (!fs::is_directory(fs::symlink_status(kept, ec)) || !has_marker(kept, kind_)) return std::nullopt;
    remove_own_files(kept, kind_);
    if (fs::exists(kept)) return std::nullopt;  // holds the user's files: leave it alone
  }
  fs::rename(staging_, kept);
  done_ = true;
  return kept;
}

}  // namespace twill
