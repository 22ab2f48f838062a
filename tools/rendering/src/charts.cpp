#include "mfpc/rendering/charts.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstdlib>
#include <fstream>

#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/error.hpp"

extern "C" char** environ;

namespace mfpc {
namespace {

// Runs gnuplot on `script` in `directory`, its stderr into `log` there: spawned directly, with no
// shell, so no file name can become a command. Returns its exit status, or -1 when it could not
// be started or did not exit.
int run_gnuplot(const std::filesystem::path& directory, const char* script, const char* log)
{
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addchdir_np(&actions, directory.c_str());
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    char* argv[] = {const_cast<char*>("gnuplot"), const_cast<char*>(script), nullptr};
    pid_t child = 0;
    const int spawned = posix_spawnp(&child, "gnuplot", &actions, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) return -1;
    int status = 0;
    while (waitpid(child, &status, 0) < 0) {
        if (errno != EINTR) return -1;
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

void require_gnuplot()
{
    if (std::system("command -v gnuplot >/dev/null 2>&1") != 0)
        throw Error("experiment", "the charts need gnuplot: install the Debian package gnuplot-nox "
                                  "(scripts/install-deps.sh does), or pass --no-charts");
}

void write_experiment_charts(const std::filesystem::path& directory, const std::string& chart_data)
{
    write_file_atomically(directory / "charts.dat", [&](std::ofstream& out) { out << chart_data; });
    struct Chart {
        const char* file;
        const char* title;
        int column;
    };
    const Chart charts[] = {{"fig11a_points.png", "Scene points after foveation", 2},
                            {"fig11b_keypoints.png", "Scene keypoints", 3},
                            {"fig11c_correspondences.png", "Correspondences", 4},
                            {"fig11d_correct_correspondences.png", "Correct correspondences", 5},
                            {"fig12a_precision.png", "Correspondence precision (Eq. 10)", 6},
                            {"fig12b_sensitivity.png", "Correspondence sensitivity (Eq. 11)", 7},
                            {"fig12c_objects.png", "Objects found: true and false instances", 8},
                            {"fig12d_time.png", "Recognition time (ms), mean and 95% interval", 10}};
    write_file_atomically(directory / "charts.gnuplot", [&](std::ofstream& out) {
        out << "set terminal pngcairo size 800,480 noenhanced font 'sans,10'\n"
               "set style fill solid 0.8 border -1\nset boxwidth 0.6\nset grid ytics\nset yrange [0:*]\n"
               "set xtics rotate by -30 left\nunset key\n";
        for (const Chart& chart : charts) {
            out << "set output '" << chart.file << "'\nset title '" << chart.title << "'\n";
            if (chart.column == 8) {
                out << "set key outside right top\nset boxwidth 0.35\n"
                       "plot 'charts.dat' using ($0-0.18):8:xtic(1) with boxes lc rgb '#2a6db0' title 'true', "
                       "'' using ($0+0.18):9 with boxes lc rgb '#a9c6e8' title 'false'\nunset key\nset boxwidth 0.6\n";
            } else if (chart.column == 10) {
                out << "plot 'charts.dat' using 0:10:xtic(1) with boxes lc rgb '#2a6db0', "
                       "'' using 0:10:11:12 with yerrorbars lc rgb 'black' pt -1\n";
            } else {
                out << "plot 'charts.dat' using 0:" << chart.column << ":xtic(1) with boxes lc rgb '#2a6db0'\n";
            }
        }
    });
    if (run_gnuplot(directory, "charts.gnuplot", "charts.log") != 0)
        throw Error("experiment", "gnuplot failed drawing the charts (see " + (directory / "charts.log").string() + ")");
}

}  // namespace mfpc
