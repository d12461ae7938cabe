// The `radiosity` pipeline of `relume process` (radiosity_pipeline.cc, docs/radiosity.md).
#pragma once

#include "apps/relume/process/pipeline.h"

namespace relume::app::process {

PipelineEntry RadiosityPipelineEntry();

}  // namespace relume::app::process
