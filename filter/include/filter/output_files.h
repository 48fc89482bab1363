// Files the program writes: each is written aside (unnamed where the file system allows, else under a temporary
// name) and renamed into place; the temporaries are removed on failure and on SIGINT/SIGTERM/SIGHUP/SIGQUIT (a
// registry the signal handler unlinks), stale ones of dead processes are removed by a later run, and no output may be
// an input.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>

namespace lensfx::filter {

// A file written aside and renamed onto `target` by commit(), else removed. Where the file system can (ext4,
// XFS, Btrfs, tmpfs) it is written unnamed (O_TMPFILE, opened again by the writers as /proc/self/fd/N): a run
// killed any way, SIGKILL and the OOM killer included, leaves nothing, and commit() names it only for the two calls
// that link and rename it, which the signal handler waits for. Elsewhere it is a named temporary beside the target
// (".NAME.lensfx-PID.EXT", the extension kept last: some writers check it) that the signal handler removes. A
// target that is a symbolic link is written through (the link stays, its file is replaced); one that is a device,
// named pipe or directory is refused (std::runtime_error), when the TempFile is made and again at commit.
class TempFile {
public:
    explicit TempFile(const std::string& target);
    TempFile(const TempFile&) = delete;
    TempFile& operator=(const TempFile&) = delete;
    ~TempFile();
    // The name it was made for, as given (its extension names the format).
    const std::string& name() const { return name_; }
    // The path to write to (a writer opens it with truncation).
    const std::string& path() const { return write_path_; }
    // Calls `write_to` with path(); an exception's message names the target where it named path().
    void write(const std::function<void(const std::string&)>& write_to);
    // Renames the temporary onto the target; throws naming both when it cannot.
    void commit();

private:
    void name_onto_target();

    std::string name_;
    std::string target_;      // name_, or the file it links to
    std::string path_;        // the temporary's name
    std::string write_path_;  // path_, or /proc/self/fd/N for the unnamed file fd_
    int fd_ = -1;
    int slot_ = -1;  // a named temporary's place in the signal handler's registry
    bool committed_ = false;
};

// Writes `bytes` to `path` through a TempFile, every write checked: throws std::runtime_error naming the
// file and the system's reason (a full disk, say), leaving neither a partial file nor the temporary.
void write_file(const std::string& path, std::string_view bytes);

// Writes `bytes` to stdout, checked (a full or closed stdout is an error, not a silent success).
void write_stdout(std::string_view bytes);

// Why a write failed, for a message: errno's text, or for EPIPE that the reader of the pipe closed it (SIGPIPE
// is caught in main, so a closed pipe is an error like any other).
std::string write_failure(int error);

// From here on SIGINT, SIGTERM, SIGHUP and SIGQUIT (those not ignored) remove the temporaries being written, leave
// one "lensfx: stopped by SIG..." line on stderr and then take their default action (the program ends killed by
// the signal). Called at the start of main; TempFile calls it too.
void handle_stopping_signals();

// Removes the temporaries (TempFile's names) in `dir` left by processes that no longer run. Returns how
// many were removed.
std::size_t remove_stale_temporaries(const std::string& dir);

// Refuses (std::runtime_error naming `option` and the path) to write `path` when it is one of the files
// that `input` names: a file, a frame pattern (every frame on disk) or "-". Also refused: `path` equal
// to another output, `other_output` (a file or pattern; "" or "-" for none).
void refuse_overwrite(const std::string& path, std::string_view option, const std::string& input,
                      const std::string& other_output = "");

// Refuses an output path (`option` names it in the message) that is a device, named pipe or directory, or a
// link to one: a file written there would replace it (as root, even /dev/null); and one whose directory does
// not exist or cannot be written (require_output_directory), before the work that would end in it. "" and
// "-" pass.
void refuse_special_output(const std::string& path, std::string_view option);
// Refuses (std::runtime_error naming `option` and the path), before any work, a file that write_file could not
// write when the work is done: its folder missing, read-only or full, or not a place for files (/proc). Writes a
// byte to a temporary beside it, which it removes; the file itself is not touched.
void require_writable_file(const std::string& path, std::string_view option);

// Throws std::runtime_error naming `path` where the directory it would be written in does not exist or is
// not writable.
void require_output_directory(const std::string& path);

// A path that names something other than a regular file (a device such as /dev/zero, a FIFO, a
// directory) is refused where a file is needed: throws std::runtime_error naming `what` and the path
// ("" for a caller that names the path itself). A path that does not exist passes: its reader says so.
void require_regular_file(const std::string& path, std::string_view what);

}  // namespace lensfx::filter
