// Timing harness for the reference (ruckig 0.19.4 C++), reading the rmd-rt bench's inputs
// (`RMD_TRAJ_BENCH_DUMP=DIR cargo bench --bench trajectory`, format in benches/trajectory.rs).
// usage: harness DIR SECONDS [fresh1|fresh6|repeated1|repeated6|all]
//   -> prints, per benchmark, the mean time per call over the timed region and the median of the
//      batch means; fresh* cycle through the file's inputs (batches of 4096 calls), repeated*
//      calculate the file's one input again and again (batches of 1000 calls).
//   SECONDS = 0: one untimed pass over the inputs (for callgrind: instructions per calculation).
// The same loop as src/main.rs (ours), so that the two binaries can be alternated (run.sh).
#include <ruckig/ruckig.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace ruckig;
using Clock = std::chrono::steady_clock;

// One input per line: per axis p0 v0 a0 pf vf af vmax vmin amax amin jmax. Exits on a malformed
// line or an empty file (a silent zero would time the wrong problem).
template <size_t N> std::vector<InputParameter<N>> load(const std::string& path) {
    std::vector<InputParameter<N>> out;
    std::ifstream f(path);
    if (!f) {
        std::fprintf(stderr, "cannot read %s\n", path.c_str());
        std::exit(2);
    }
    std::string line;
    while (std::getline(f, line)) {
        std::istringstream ss(line);
        InputParameter<N> in;
        std::array<double, N> vmin, amin;
        for (size_t i = 0; i < N; ++i) {
            double t[11];
            for (auto& x : t) {
                // strtod, not operator>>: the latter fails on subnormal values.
                std::string tok;
                char* end = nullptr;
                if (ss >> tok) x = std::strtod(tok.c_str(), &end);
                if (end == nullptr || end == tok.c_str() || *end != '\0') {
                    std::fprintf(stderr, "%s:%zu: expected %zu numbers per line\n", path.c_str(), out.size() + 1, 11 * N);
                    std::exit(2);
                }
            }
            in.current_position[i] = t[0];
            in.current_velocity[i] = t[1];
            in.current_acceleration[i] = t[2];
            in.target_position[i] = t[3];
            in.target_velocity[i] = t[4];
            in.target_acceleration[i] = t[5];
            in.max_velocity[i] = t[6];
            vmin[i] = t[7];
            in.max_acceleration[i] = t[8];
            amin[i] = t[9];
            in.max_jerk[i] = t[10];
        }
        in.min_velocity = vmin;
        in.min_acceleration = amin;
        out.push_back(in);
    }
    if (out.empty()) {
        std::fprintf(stderr, "%s: no inputs\n", path.c_str());
        std::exit(2);
    }
    return out;
}

static volatile int sink;

// Not inlined: callgrind's --toggle-collect='void run<*' counts exactly this function.
template <size_t N>
__attribute__((noinline)) void run(const char* name, const std::vector<InputParameter<N>>& ins, double secs, bool repeated) {
    Ruckig<N> otg;
    Trajectory<N> traj;
    int fails = 0;
    for (auto& in : ins) fails += otg.calculate(in, traj) != Result::Working;
    const size_t n = ins.size();
    if (secs == 0) { std::printf("ref %s: one pass, %d not Working\n", name, fails); return; }
    const size_t batch = repeated ? 1000 : 4096;
    std::vector<double> per_call;
    size_t k = 0;
    double total_ns = 0;
    size_t total_calls = 0;
    // warm-up 0.5 s
    auto w0 = Clock::now();
    while (std::chrono::duration<double>(Clock::now() - w0).count() < 0.5) {
        for (size_t b = 0; b < batch; ++b) { k = (k + 1) % n; sink = (int)otg.calculate(ins[k], traj); }
    }
    auto t0 = Clock::now();
    while (std::chrono::duration<double>(Clock::now() - t0).count() < secs) {
        auto a = Clock::now();
        for (size_t b = 0; b < batch; ++b) { k = (k + 1) % n; sink = (int)otg.calculate(ins[k], traj); }
        auto e = Clock::now();
        double ns = std::chrono::duration<double, std::nano>(e - a).count();
        per_call.push_back(ns / batch);
        total_ns += ns;
        total_calls += batch;
    }
    std::sort(per_call.begin(), per_call.end());
    std::printf("ref %-10s mean %.3f us  median(batch) %.3f us  (%zu calls, %d of %zu inputs not Working)\n", name,
                total_ns / total_calls / 1000.0, per_call[per_call.size() / 2] / 1000.0, total_calls, fails, n);
}

int main(int argc, char** argv) {
    std::string dir = argc > 1 ? argv[1] : "inputs";
    double secs = argc > 2 ? std::atof(argv[2]) : 3.0;
    std::string which = argc > 3 ? argv[3] : "all";
    bool known = which == "all" || which == "fresh1" || which == "fresh6" || which == "repeated1" || which == "repeated6";
    if (!known || secs < 0) {
        std::fprintf(stderr, "usage: harness DIR SECONDS [fresh1|fresh6|repeated1|repeated6|all]\n");
        return 2;
    }
    if (which == "all" || which == "fresh1") run<1>("fresh1", load<1>(dir + "/fresh1.txt"), secs, false);
    if (which == "all" || which == "fresh6") run<6>("fresh6", load<6>(dir + "/fresh6.txt"), secs, false);
    if (which == "all" || which == "repeated1") run<1>("repeated1", load<1>(dir + "/repeated1.txt"), secs, true);
    if (which == "all" || which == "repeated6") run<6>("repeated6", load<6>(dir + "/repeated6.txt"), secs, true);
}
