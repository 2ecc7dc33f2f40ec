#include "cli_error.h"

#include <iostream>

#include "sawyer/core/option_names.h"

namespace sawyer::app {
namespace {

// Library option → flag, for every option a library names in its messages.
constexpr OptionName kFlags[] = {
    {"rot_step_deg", "--rot-step"},
    {"offset_x_max_mm", "--offsets"},
    {"offset_x_step_mm", "--offset-step"},
    {"offset_y_max_mm", "--offsets-y"},
    {"offset_y_step_mm", "--offset-y-step"},
    {"sigma_rot_deg", "--sigma-rot"},
    {"sigma_offset_mm", "--sigma-offset"},
    {"model_draws", "--scan-draws"},
    {"SawNames::position", "--position"},
    {"ImageSize", "--size"},
    {"FaceLayout::supersample", "--supersample"},
    {"face_mask", "--face"},
    {"BoardBox::from_string", "--board"},
    {"shard_spec", "--shard"},
    {"RenderJob::boards", "--board"},
    {"RenderOptions::species", "--species"},
    {"RenderJob::section_z", "--section"},
    {"RenderJob::longitudinal_deg", "--longitudinal"},
    {"RenderJob::offset_mm", "--offset"},
    {"RenderJob::view", "--view"},
    {"RenderJob::yaw_deg", "--yaw"},
    {"RenderJob::pitch_deg", "--pitch"},
    {"RenderJob::distance_mm", "--distance"},
    {"RenderJob::look_at_z", "--look-at"},
    {"RenderJob", "sawyer render"},
    {"WoodFieldParams::knot_noise", "--knot-noise"},
    {"RunJobOptions::output", "-o"},
    {"ExportOptions::output", "-o"},
    {"ExportOptions::osl_data", "--osl-data"},
    {"ExportOptions::boards_in_scanner_frame", "--scanner-frame"},
    {"ExportOptions::boards", "--board"},
    {"ExportOptions", "sawyer export"},
    {"BakeOptions::px_per_mm", "--px-per-mm"},
    {"BakeOptions::supersample", "--supersample"},
    {"RunJobOptions::db", "--db"},
    {"RunJobOptions::no_register", "--no-register"},
    {"LogFilter::order_by", "--sort"},
    {"eccentricity_min", "--eccentricity"},
    {"eccentricity_max", "--eccentricity"},
    {"eccentricity_change", "--eccentricity-change"},
    {"eccentricity_turn_rad", "--eccentricity-turn-rad"},
    // The phantom's and the CT readers' options are their flags, '_' for '-', but for three.
    {"PhantomOptions::image_size", "--size"},
    {"PhantomOptions::slice_spacing_mm", "--spacing-mm"},
    {"PhantomOptions::slice_thickness_mm", "--thickness-mm"},
    {"PhantomOptions::", "--"},
    {"PhantomWriteOptions::", "--"},
    {"Placement::", "--"},
    {"OpenOptions::", "--"},
};

}  // namespace

std::string with_flags(const std::string& text) { return with_option_names(text, kFlags); }

int fail(const Error& e) {
  std::cerr << "sawyer: " << with_flags(e.message()) << "\n";
  return 1;
}

}  // namespace sawyer::app
