// A frame's RGB working buffer as the detector's image view (kept out of frame.h, so that image I/O and the
// OpenImageIO module do not depend on the detector's headers).
#pragma once

#include <detect/image_view.h>
#include <filter/frame.h>

namespace lensfx::filter {

// The RGB working buffer as the detector's input; positions come out in display-window pixels.
detect::ImageView rgb_view(const Frame& frame);

}  // namespace lensfx::filter
