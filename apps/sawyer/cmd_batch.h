// `sawyer batch <manifest.csv> -o <dir> [--jobs N] [--shard i/N] [--db FILE] [-- run options]`:
// runs `sawyer run` on every CT scan of a manifest (or of one shard of it), each log in its own
// subprocess, at most --jobs at once; a failed log is reported and the batch goes on
// (docs/batch.md).
//
// Exit codes: 0 every log of the shard ok (or the shard is empty), 2 some failed, 1 the batch
// could not start (bad manifest, shard, options or register).
//
//   std::function<int()> run_batch;
//   add_batch_command(app, run_batch);   // before app.parse()
//   ...
//   if (run_batch) return run_batch();   // after it: set only when the subcommand was given
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace sawyer::app {

// Adds the `batch` subcommand to `app`. When the command line selects it, parsing sets `run` to
// a function that does the work and returns the exit code (0, 2, or 1 with one line on stderr).
void add_batch_command(CLI::App& app, std::function<int()>& run);

}  // namespace sawyer::app
