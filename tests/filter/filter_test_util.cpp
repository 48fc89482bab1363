// Helpers of the filter's end-to-end tests (see filter_test_util.h).
#include "filter_test_util.h"
#include "run_lensfx.h"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>

#include <filter/image_io.h>

namespace lensfx::test {

namespace fs = std::filesystem;

RunResult run(const std::string& command) {
    const fs::path err = fs::temp_directory_path() / fmt::format("lensfx-test-stderr-{}", ::getpid());
    const fs::path script = fs::temp_directory_path() / fmt::format("lensfx-test-cmd-{}.sh", ::getpid());
    std::ofstream(script) << "set -o pipefail\n" << command << "\n";
    const std::string line = fmt::format("bash \"{}\" 2>\"{}\"", script.string(), err.string());
    const int status = std::system(line.c_str());
    fs::remove(script);
    RunResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream in(err);
    std::stringstream ss;
    ss << in.rdbuf();
    r.stderr_text = ss.str();
    fs::remove(err);
    return r;
}

std::string lensfx_cmd() { return lensfx_path(); }

fs::path scratch_dir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / fmt::format("lensfx-test-{}-{}", name, ::getpid());
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::string compare_images(const std::string& expected, const std::string& actual, bool check_attributes) {
    filter::Frame a, b;
    try {
        a = filter::read_image(expected);
        b = filter::read_image(actual);
    } catch (const std::exception& e) {
        return e.what();
    }
    const auto& s = a.spec;
    const auto& t = b.spec;
    if (s.channelnames != t.channelnames) return "channel names differ";
    for (int c = 0; c < s.nchannels(); ++c) {
        if (s.channel_type(c) != t.channel_type(c)) return fmt::format("channel {} type differs", s.channel_name(c));
    }
    if (s.x != t.x || s.y != t.y || s.width != t.width || s.height != t.height) return "data window differs";
    if (s.full_x != t.full_x || s.full_y != t.full_y || s.full_width != t.full_width || s.full_height != t.full_height)
        return "display window differs";
    if (a.pixels.size() != b.pixels.size() || std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size()) != 0)
        return "pixels differ";
    if (check_attributes) {
        // Every attribute of the files as OpenImageIO sees them, independently of how lensfx reads them.
        auto in_a = OIIO::ImageInput::open(expected), in_b = OIIO::ImageInput::open(actual);
        if (!in_a || !in_b) return "OpenImageIO cannot open the images";
        const OIIO::ImageSpec sa = in_a->spec(), sb = in_b->spec();
        for (const auto& p : sa.extra_attribs) {
            const std::string name = p.name().string();
            // The file's tiling and mip levels are not part of a frame: outputs are scanline files.
            if (name == "DateTime" || name.rfind("oiio:", 0) == 0 || name == "openexr:levelmode" ||
                name == "openexr:roundingmode")
                continue;
            const OIIO::ParamValue* q = sb.find_attribute(name);
            if (!q) return fmt::format("attribute {} missing", name);
            if (q->type() != p.type() || q->get_string() != p.get_string())
                return fmt::format("attribute {} differs: {} vs {}", name, p.get_string(), q->get_string());
        }
    }
    return "";
}

std::size_t file_count(const fs::path& dir) {
    std::size_t n = 0;
    for (const auto& e : fs::directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
    return n;
}

}  // namespace lensfx::test
