// Files the program writes: each is written aside under a temporary name and renamed into place, the
// temporaries are removed on failure and on SIGINT/SIGTERM/SIGHUP/SIGQUIT (a registry the signal handler
// unlinks), stale ones of dead processes are removed by a later run, and no output may be an input.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace lensfx::filter {

// A temporary file beside `target` (".NAME.lensfx-PID.EXT", the extension kept last: some writers check
// it), removed unless commit() renamed it into place, and removed by the signal handler if the program
// is interrupted meanwhile. A target that is a symbolic link is written through (the link stays, its file
// is replaced); one that is a device, named pipe or directory is refused (std::runtime_error), when the
// TempFile is made and again at commit.
class TempFile {
public:
    explicit TempFile(const std::string& target);
    TempFile(const TempFile&) = delete;
    TempFile& operator=(const TempFile&) = delete;
    ~TempFile();
    const std::string& path() const { return path_; }
    // Renames the temporary onto the target; throws naming both when it cannot.
    void commit();

private:
    std::string target_;
    std::string path_;
    int slot_ = -1;  // in the signal handler's registry
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

// Throws std::runtime_error naming `path` where the directory it would be written in does not exist or is
// not writable.
void require_output_directory(const std::string& path);

// A path that names something other than a regular file (a device such as /dev/zero, a FIFO, a
// directory) is refused where a file is needed: throws std::runtime_error naming `what` and the path
// ("" for a caller that names the path itself). A path that does not exist passes: its reader says so.
void require_regular_file(const std::string& path, std::string_view what);

}  // namespace lensfx::filter
