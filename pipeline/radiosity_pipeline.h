// The `radiosity` pipeline of `relume process` (radiosity_pipeline.cc, docs/radiosity.md).
#pragma once

#include "pipeline/pipeline.h"

namespace relume::pipeline {

PipelineEntry RadiosityPipelineEntry();

}  // namespace relume::pipeline
