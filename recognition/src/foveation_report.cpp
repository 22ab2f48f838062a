#include "mfpc/recognition/foveation_report.hpp"

#include <cstdio>

#include <nlohmann/json.hpp>

#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/core/error.hpp"
#include "json_fields.hpp"

namespace mfpc {
namespace {

using nlohmann::ordered_json;
using detail::group_digits;

const FoveatedCloud& result_of(const FoveationReport& report)
{
    if (report.result == nullptr) throw Error("foveation report", "no foveation result to report");
    return *report.result;
}

// The regions a report lists: mode single foveates with one structure only.
std::vector<RegionSummary> listed_regions(const FoveationReport& report)
{
    std::vector<RegionSummary> regions;
    for (const RegionSummary& region : result_of(report).regions)
        if (report.mode != FoveationMode::single || region.structure == report.single_structure)
            regions.push_back(region);
    return regions;
}

std::size_t redundant_removed(const FoveationReport& report)
{
    return report.mode == FoveationMode::mfpc ? result_of(report).redundant_points : 0;
}

}  // namespace

std::string to_json(const FoveationReport& report)
{
    const FoveatedCloud& result = result_of(report);
    ordered_json regions = ordered_json::array();
    for (const RegionSummary& region : listed_regions(report)) {
        regions.push_back({{"structure", region.structure},
                           {"level", region.level},
                           {"density", region.density},
                           {"points_before", region.points_before},
                           {"points_after", region.points_after}});
    }
    ordered_json timings = ordered_json::object();
    for (const auto& [step, ms] : report.timings_ms) timings[step] = ms;
    const ordered_json json = {
        {"input", report.input},
        {"mode", to_string(report.mode)},
        {"downsample", to_string(report.downsample)},
        {"structures", report.structures},
        {"levels", report.levels},
        {"points_in", report.points_in},
        {"points_finite", report.points_finite},
        {"points_before_downsampling", result.points_before_downsampling},
        {"points_out", result.cloud.size()},
        {"redundant_points_removed", redundant_removed(report)},
        {"duplicate_points", report.mode == FoveationMode::raw ? result.redundant_points : 0},
        {"regions", regions},
        {"timings_ms", timings},
        {"threads", report.threads},
        {"warnings", report.warnings},
        {"placement", report.placement ? ordered_json::parse(to_json(*report.placement)) : ordered_json(nullptr)},
    };
    return detail::json_text(json);
}

std::string to_table(const FoveationReport& report)
{
    const FoveatedCloud& result = result_of(report);
    std::vector<std::pair<std::string, std::string>> rows = {
        {"input", report.input},
        {"mode", to_string(report.mode)},
    };
    if (report.placement) rows.emplace_back("placement", summary(*report.placement));
    rows.insert(rows.end(), {
        {"downsample", to_string(report.downsample)},
        {"structures", std::to_string(report.structures) + " (levels m = " + std::to_string(report.levels) + ")"},
        {"points in", group_digits(report.points_in)},
        {"points finite", group_digits(report.points_finite)},
        {"before downsampling", group_digits(result.points_before_downsampling)},
        {"points out", group_digits(result.cloud.size())},
        {"redundant removed", group_digits(redundant_removed(report))},
    });
    if (!report.output.empty()) rows.emplace_back("output", report.output);
    std::string out = detail::key_value_rows(rows);
    out += "\nstructure  level  density (m)  points before  points after\n";
    for (const RegionSummary& region : listed_regions(report)) {
        char line[128];
        std::snprintf(line, sizeof line, "%9d  %5d  %11.4f  %13zu  %12zu\n", int(region.structure), int(region.level),
                      double(region.density), region.points_before, region.points_after);
        out += line;
    }
    out += "\ntimings (ms)";
    for (const auto& [step, ms] : report.timings_ms) out += "  " + step + " " + detail::format_fixed(ms, 2);
    return out + '\n';
}

std::vector<RegionCloud> region_clouds(const FoveatedCloud& foveated)
{
    if (foveated.labels.size() != foveated.cloud.size())
        throw Error("foveation", std::to_string(foveated.labels.size()) + " labels for " +
                                     std::to_string(foveated.cloud.size()) + " points");
    std::vector<RegionCloud> regions;
    for (std::size_t begin = 0; begin < foveated.cloud.size();) {
        std::size_t end = begin;
        std::vector<std::uint32_t> indices;
        while (end < foveated.cloud.size() && foveated.labels[end] == foveated.labels[begin])
            indices.push_back(std::uint32_t(end++));
        const RegionLabel label = foveated.labels[begin];
        regions.push_back({label,
                           "structure" + std::to_string(label.structure) + "_level" + std::to_string(label.level) +
                               ".pcd",
                           select(foveated.cloud, indices)});
        begin = end;
    }
    return regions;
}

}  // namespace mfpc
