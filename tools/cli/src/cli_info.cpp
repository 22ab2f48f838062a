#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/box.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/index/nearest_neighbors.hpp"

namespace mfpc::cli {

namespace {

struct InfoOptions {
    std::string cloud;
};

nlohmann::ordered_json to_json(const Eigen::Vector3f& v) { return {v.x(), v.y(), v.z()}; }

std::string format_vector(const Eigen::Vector3f& v)
{
    return "(" + format_fixed(v.x(), 4) + ", " + format_fixed(v.y(), 4) + ", " + format_fixed(v.z(), 4) + ")";
}

void run_info(const InfoOptions& options, const GlobalOptions& global)
{
    CloudReadReport report;
    const PointCloud cloud = read_cloud(options.cloud, &report);
    const Box box = bounding_box(cloud.points);
    const double spacing = mean_spacing(cloud.points);

    std::string fields;
    for (const auto& f : report.fields) fields += (fields.empty() ? "" : " ") + f;

    if (print_table(global)) {
        std::vector<std::pair<std::string, std::string>> rows = {
            {"file", options.cloud},
            {"encoding", to_string(report.encoding)},
            {"points", group_digits(report.points_in)},
            {"finite", group_digits(report.points_finite) + " (" +
                           group_digits(report.points_in - report.points_finite) +
                           (report.points_zero > 0
                                ? " dropped: " + group_digits(report.points_zero) + " invalid pixels at (0, 0, 0), the rest non-finite)"
                                : std::string(" non-finite dropped)"))},
            {"organized", report.height > 1 ? std::to_string(report.width) + " x " + std::to_string(report.height)
                                            : std::string("no")},
            {"fields", fields},
            {"bounding box min", format_vector(box.min)},
            {"bounding box max", format_vector(box.max)},
            {"size", format_vector(box.size())},
            {"mean spacing", cloud.size() < 2 ? std::string("n/a (fewer than 2 finite points)")
                                              : format_fixed(spacing * 1000.0, 3) + " mm (mean distance to the nearest point)"},
        };
        print_rows(rows);
    }
    write_json(global, {
        {"file", options.cloud},
        {"encoding", to_string(report.encoding)},
        {"points", report.points_in},
        {"points_finite", report.points_finite},
        {"points_zero", report.points_zero},
        {"organized", report.height > 1},
        {"width", report.width},
        {"height", report.height},
        {"fields", report.fields},
        {"has_normals", cloud.has_normals()},
        {"has_colors", cloud.has_colors()},
        {"bounding_box", {{"min", to_json(box.min)}, {"max", to_json(box.max)}}},
        {"mean_spacing", cloud.size() < 2 ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(spacing)},
    });
}

}  // namespace

void add_info_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<InfoOptions>();
    CLI::App* command = app.add_subcommand(
        "info", "Print a cloud's point count, finite count, organized size, fields, bounding box and mean spacing");
    command->add_option("CLOUD", options->cloud, "Point cloud (.pcd or .ply)")->required();
    command->callback([options, &global] { run_info(*options, global); });
}

}  // namespace mfpc::cli
