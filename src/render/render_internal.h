// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Internal helpers shared by the files of src/render/.
#ifndef DDOC_SRC_RENDER_RENDER_INTERNAL_H_
#define DDOC_SRC_RENDER_RENDER_INTERNAL_H_

#include <string>

#include "ddoc/render/render_settings.h"

namespace ddoc {

/// The checks of RenderSettings::Validate that do not involve the output directory (sizes,
/// fps, camera, quality); used by OffscreenRenderer::Create, which writes no files.
bool ValidateRenderGeometry(const RenderSettings& settings, std::string* error);

}  // namespace ddoc

#endif  // DDOC_SRC_RENDER_RENDER_INTERNAL_H_
