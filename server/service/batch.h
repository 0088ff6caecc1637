// Batch rendering without HTTP (myriad-server --batch SPEC --index I --out DIR): a job spec names
// a snapshot and a camera path; index I renders its share of the path's frames with the same
// session code as the HTTP API (a session made from the snapshot, its camera set, the frame
// rendered and encoded as GET .../frame does), so a batch frame is byte-equal to the one the API
// answers for the same state and query. Kubernetes Indexed Jobs run one index per pod
// (deploy/k8s/batch-job.yaml, JOB_COMPLETION_INDEX); docs/deploy.md describes the spec.
//
//   {
//     "snapshot": SNAPSHOT,               // GET /v1/sessions/{id}/snapshot; built-in or library model
//     "cameras": [CAMERA, ...],           // the camera path: frame i is rendered from cameras[i]
//     "frame": "width=640&height=360&format=png",  // GET .../frame's query (target, format, width,
//                                                  // height, quality, time)
//     "framesPerIndex": 10,               // index I renders frames I*K .. I*K+K-1 (those that exist)
//     "targets": {"final": "png", "depth": "exr", "instance-id": "png16"}   // optional: a dataset
//   }
//
// Without "targets": frames go to DIR/frame-NNNNNN.EXT (EXT png, jpg, raw, npy, exr or npz;
// NNNNNN the frame's number on the path), each written atomically, so a retried pod rewrites
// whole files only. With "targets" (each target's format: final png or npy; depth and the ids
// png16, npy or exr; the other targets npy or exr): each frame is ONE render whose targets are
// written as DIR/<target>_<NNNNN>.<ext> (NNNNN the frame's number, 5 digits; ext png, npy or
// exr), and DIR/metadata.json lists every frame written so far (the dataset layout, docs/deploy.md
// "Datasets"; the Python client's writer makes the same): merged under a lock on
// DIR/metadata.json.lock, so the indices of a job may write one directory together.
#pragma once

#include <cstdint>
#include <string>

#include "service/api.h"

namespace myriad::service {

struct BatchJob {
  std::string specPath;
  uint32_t index = 0;
  std::string outDir;
};

// Renders job.index's frames; returns how many were written. Throws std::runtime_error with one
// sentence (a bad spec names the member) or ProblemError (a snapshot that does not load).
size_t runBatch(ApiContext& context, const BatchJob& job);

}  // namespace myriad::service
