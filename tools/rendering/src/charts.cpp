#include "mfpc/rendering/charts.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/detail/text_file.hpp"
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

void write_scaling_charts(const std::filesystem::path& directory)
{
    // The ideal speed-up line is threads / the first row's threads.
    const std::string data = read_text_file(directory / "scaling.csv");
    const std::size_t row = data.find('\n');
    const std::size_t comma = row == std::string::npos ? std::string::npos : data.find(',', row);
    const std::string first = comma == std::string::npos ? "1" : data.substr(row + 1, comma - row - 1);
    if (first.empty() || first.find_first_not_of("0123456789") != std::string::npos)
        throw Error((directory / "scaling.csv").string(), "its first row does not start with a thread count");
    // Placement's efficiency (column 8) is drawn only for a batch that placed: 0 on every row otherwise.
    bool placed = false;
    std::istringstream rows(data.substr(row == std::string::npos ? data.size() : row + 1));
    for (std::string line; std::getline(rows, line);) {
        std::istringstream fields(line);
        std::string field;
        int column = 0;
        while (column < 8 && std::getline(fields, field, ',')) ++column;
        placed = placed || (column == 8 && std::strtod(field.c_str(), nullptr) != 0.0);
    }
    write_file_atomically(directory / "scaling.gnuplot", [&](std::ofstream& out) {
        out << "first = " << first << ".0\n"
               "set terminal pngcairo size 800,480 noenhanced font 'sans,10'\n"
               "set datafile separator ','\nset key left top\nset grid\n"
               "set xlabel 'worker threads'\nset logscale x 2\nset yrange [0:*]\n"
               "set output 'scaling_throughput.png'\nset title 'Batch throughput'\nset ylabel 'scenes per second'\n"
               "plot 'scaling.csv' using 1:4 skip 1 with linespoints lw 2 pt 7 title 'throughput'\n"
               "set output 'scaling_speedup.png'\nset title 'Speed-up against the first thread count'\n"
               "set ylabel 'speed-up'\n"
               "plot 'scaling.csv' using 1:5 skip 1 with linespoints lw 2 pt 7 title 'measured', "
               "'' using 1:($1/first) skip 1 with lines dt 2 title 'ideal'\n"
               "set output 'scaling_efficiency.png'\nset title 'Efficiency (1 = ideal)'\nset ylabel 'efficiency'\n"
               "set yrange [0:1.5]\n"
               "plot 'scaling.csv' using 1:6 skip 1 with linespoints lw 2 pt 7 title 'end to end', "
               "'' using 1:7 skip 1 with linespoints title 'read', "
            << (placed ? "'' using 1:8 skip 1 with linespoints title 'place', " : "")
            << "'' using 1:9 skip 1 with linespoints title 'describe', '' using 1:10 skip 1 with linespoints title "
               "'models'\n";
    });
    if (run_gnuplot(directory, "scaling.gnuplot", "scaling.log") != 0)
        throw Error("scaling", "gnuplot failed drawing the charts (see " + (directory / "scaling.log").string() + ")");
}

}  // namespace mfpc
