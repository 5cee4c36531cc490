#pragma once
// Where `twill fit` writes, and the rules that keep it from destroying anything it did not
// create (issue #13; docs/reliability.md §1).
//
// - Every folder twill fills carries a marker file (kFitMarkerFile). A folder with the marker is
//   a previous twill output; twill's own files in it are the names in fit_output_file_names().
// - OUTDIR may be new, empty, or a previous twill output. An existing non-empty folder without
//   the marker is refused unless `force`; even then twill only writes (and so replaces) files
//   with its own names and deletes nothing else. A file (not a folder) is never replaced, and a
//   dataset folder (one holding fabric.yaml, or the dataset being fitted) is never an OUTDIR.
// - Everything is checked, and the staging folder OUTDIR.partial created with its marker,
//   before any work starts (so an unwritable OUTDIR fails in the first second, not after the
//   fit). The outputs are written into OUTDIR.partial and renamed to OUTDIR in one step when
//   OUTDIR is new or held only twill's files (rename(2) replaces an empty folder atomically);
//   otherwise each file is renamed into place (each atomically), the marker last.
// - A failed fit removes OUTDIR.partial, or keeps it as OUTDIR.incomplete when an incomplete
//   report was written into it (keep_incomplete()): never an OUTDIR that looks complete.
#include <filesystem>
#include <functional>
#include <optional>
#include <set>
#include <string>

namespace twill {

/// The marker file in every folder twill fit fills.
inline constexpr const char* kFitMarkerFile = ".twill-fit";

/// Every file name twill fit may write into an output folder (outputs, figures, the incomplete
/// report, the marker): the only files it ever replaces or removes.
const std::set<std::string>& fit_output_file_names();

/// `name` as one safe path component: letters, digits, '.', '-', '_' kept, every other run of
/// bytes one '_', no leading or trailing '.'/'_', at most 64 bytes; "dataset" when nothing is
/// left. "/../../../ESCAPED" -> "ESCAPED", "my fabric" -> "my_fabric".
std::string safe_path_component(const std::string& name);

/// out/fit-<safe name>: the default OUTDIR of a dataset.
std::filesystem::path default_fit_folder(const std::string& dataset_name);

/// What one command writes into its output folders: the rules above hold for each, with its
/// own marker and file names (twill fit's; twill report's, study/report.hpp).
struct OutputFolderKind {
  std::string command;  ///< e.g. "twill fit", for messages and the marker's text
  std::string marker;   ///< the marker file's name
  std::string files;    ///< the command's file names, for the marker's text
  std::string source;   ///< what the folder it reads is, e.g. "dataset": never an output folder
  std::function<bool(const std::string& name)> owns;  ///< a file name the command writes
};

/// twill fit's kind: kFitMarkerFile and fit_output_file_names().
const OutputFolderKind& fit_output_kind();

class OutputFolder {
 public:
  /// Checks `out` against the rules above and creates `out`.partial with the marker. Throws
  /// InputError (located at `option`, e.g. "-o") when `out` is not acceptable or not writable.
  /// `source_folder` (the dataset a fit reads; may be empty) is never an output folder.
  OutputFolder(const OutputFolderKind& kind, std::filesystem::path out, const std::string& source_folder, bool force,
               const std::string& option = "-o");
  /// Removes the staging folder unless commit() or keep_incomplete() moved it.
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  const std::filesystem::path& out() const { return out_; }
  /// OUTDIR.partial: write every output here.
  const std::filesystem::path& staging() const { return staging_; }
  /// Moves the staged outputs into OUTDIR (see the header comment).
  void commit();
  /// Keeps the staging folder (holding an incomplete report) as OUTDIR.incomplete and returns
  /// that path; nullopt when OUTDIR.incomplete exists and is not twill's (then nothing is kept).
  std::optional<std::filesystem::path> keep_incomplete();

 private:
  const OutputFolderKind& kind_;
  std::filesystem::path out_, staging_;
  bool out_was_ours_ = false;
  bool done_ = false;
};

/// The output folder of `twill fit`.
class FitOutputFolder : public OutputFolder {
 public:
  FitOutputFolder(std::filesystem::path out, const std::string& dataset_folder, bool force,
                  const std::string& option = "-o")
      : OutputFolder(fit_output_kind(), std::move(out), dataset_folder, force, option) {}
};

}  // namespace twill
