// TEMPORARY: the render thread moved to render/ (render/render_thread.h) and the service sees it
// through render::RenderQueue (render/render_queue.h). This header keeps the old names compiling
// until the session files include render/render_queue.h themselves; delete it then.
#pragma once

#include "render/render_queue.h"

namespace myriad::service {
using render::RenderQueueFullError;
using RenderThread = render::RenderQueue;
}  // namespace myriad::service
