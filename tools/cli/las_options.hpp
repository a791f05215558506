#pragma once
// --las-version, --scale, --offset and --crs: how a LAS output is written (io::LasWriteOptions).
#include <filesystem>

#include "arguments.hpp"
#include "pointfair/io/las.hpp"

namespace pointfair::cli {

/// Registers the four options, filling `options`.
void add_las_options(ArgumentParser& parser, io::LasWriteOptions& options);

/// Throws UsageError when any of them was given for an output that is not a .las file.
void require_las_output(const io::LasWriteOptions& options, const std::filesystem::path& output);

}  // namespace pointfair::cli
