#include "pipeline/process.h"

#include "capture/folder_lock.h"
#include "core/error.h"

namespace relume::pipeline {

ProcessResult ProcessSession(const PipelineRequest& request,
                             const std::function<void(const PipelineReport&)>& on_done) {
  const bool all = request.pipeline.empty() || request.pipeline == "all";
  CheckSettings(request.settings, all ? "all" : request.pipeline);
  PrepareOutputFolder(request.out_dir);
  const capture::FolderLock lock = capture::FolderLock::Acquire(request.out_dir, "process");
  ProcessResult result;
  const auto done = [&](PipelineReport report) {
    result.reports.push_back(std::move(report));
    if (on_done) on_done(result.reports.back());
  };
  if (!all) {
    done({request.pipeline, request.out_dir, RunPipeline(request), ""});
  } else {
    for (const PipelineEntry& entry : Pipelines()) {
      PipelineRequest one = request;
      one.pipeline = entry.name;
      one.out_dir = request.out_dir / entry.name;
      try {
        done({entry.name, one.out_dir, RunPipeline(one), ""});
      } catch (const InvalidArgumentError& e) {
        done({entry.name, one.out_dir, nullptr, e.what()});
      } catch (const Error& e) {
        result.failed.push_back(entry.name);
        done({entry.name, one.out_dir, nullptr, std::string("failed: ") + e.what()});
      }
    }
  }
  if (!request.explain) {
    result.report = WriteReport(capture::SessionReader(request.session_dir), request.out_dir, result.reports);
  }
  return result;
}

}  // namespace relume::pipeline
