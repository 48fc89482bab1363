// seeds_measured FIRST LAST [END [STEP [LENS]]]: the fit test's synthetic sweep (tests/measured/
// synthetic_sweep.h; 0..END degrees by STEP, default 0..16 by 1) fitted once per noise seed FIRST..LAST;
// a table of issue 19's figures per seed (relative L1 in 8x8 blocks and power error at the check angles,
// predict's Spearman over 0..END) and the worst of each column: how robust the fit is to the noise.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "synthetic_sweep.h"

int main(int argc, char** argv) {
    using namespace lensfx::measured;
    if (argc < 3) {
        std::fprintf(stderr, "usage: seeds_measured FIRST LAST [END [STEP [LENS]]]\n");
        return 2;
    }
    const unsigned long first = std::stoul(argv[1]), last = std::stoul(argv[2]);
    const double end = argc > 3 ? std::stod(argv[3]) : 16.0, step = argc > 4 ? std::stod(argv[4]) : 1.0;
    synthetic::PhysicalLens lens(argc > 5 ? argv[5] : "petzval-kodak");
    const std::vector<SweepFrame> clean = synthetic::clean_sweep(lens, end, step);
    const auto& angles = synthetic::check_angles();
    std::string header = "seed |";
    for (const auto& [ax, ay] : angles) header += fmt::format(" L1({:g},{:g})", ax, ay);
    header += " |";
    for (const auto& [ax, ay] : angles) header += fmt::format(" P({:g},{:g})", ax, ay);
    fmt::print("{} | Spearman 0..{:g} | ghosts | fit s\n", header, end);
    std::vector<double> worst(angles.size() * 2, 0.0);
    double worst_rho = 1.0;
    for (unsigned long seed = first; seed <= last; ++seed) {
        const auto t0 = std::chrono::steady_clock::now();
        const FitResult fit = fit_sweep(synthetic::captured(clean, seed), synthetic::fit_options());
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::string l1s, powers;
        for (std::size_t i = 0; i < angles.size(); ++i) {
            const synthetic::Accuracy a = synthetic::accuracy_at(lens, fit.lens, angles[i].first, angles[i].second);
            l1s += fmt::format(" {:.3f}", a.l1), powers += fmt::format(" {:.3f}", a.power);
            worst[i] = std::max(worst[i], a.l1), worst[angles.size() + i] = std::max(worst[angles.size() + i], a.power);
        }
        const double rho = synthetic::predicted_rank_correlation(lens, fit.lens, end);
        worst_rho = std::min(worst_rho, rho);
        fmt::print("{:4} |{} |{} | {:.3f} | {} | {:.1f}\n", seed, l1s, powers, rho, fit.lens.ghosts.size(), seconds);
        std::fflush(stdout);
    }
    std::string l1s, powers;
    for (std::size_t i = 0; i < angles.size(); ++i) l1s += fmt::format(" {:.3f}", worst[i]), powers += fmt::format(" {:.3f}", worst[angles.size() + i]);
    fmt::print("worst |{} |{} | {:.3f}\n", l1s, powers, worst_rho);
    return 0;
}
