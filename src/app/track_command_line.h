// `stance bvh track`'s options: one clip (BvhTrackCommand, commands.h) or several
// (BvhTrackBatchCommand, track_batch.h) from one command line, and the video's and the viewer's
// options of a single clip. batch.track holds every clip's options, so that one clip's command
// is batch.track with its file, and a batch's is batch as it is.
#pragma once

#include <string>

#include "app/track_batch.h"
#include "params/option_meta.h"

namespace stance {

struct BvhTrackCommandLine {
  BvhTrackBatchCommand batch;
  // --record (one clip): the video (viz/viz_commands.h: TrackVideoOptions)
  std::string camera = "side";
  std::string size = "640x360";
  std::string debug_draw = "off";
  double fps = 30;
  double quit_after_s = 0;  // --view: close after this much wall time

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    BvhTrackCommand& t = batch.track;
    v("inputs", batch.inputs,
      OptionMeta{.help = "BVH files, folders or quoted globs (more than one: OUT/<clip>/ each, and "
                         "OUT/results.csv)",
                 .names = "input",
                 .required = true});
    v("out_dir", t.out_dir,
      OptionMeta{.help = "output folder (track.yaml, summary.json, log.csv, tracked.bvh)",
                 .names = "--out"});
    v("jobs", batch.jobs,
      OptionMeta{.help = "several clips: clips at once per process (default: one per thread)",
                 .min = 0});
    v("resume", batch.resume,
      OptionMeta{.help = "several clips: keep --out's finished clips, track the rest"});
    v("plot", batch.plot,
      OptionMeta{.help = "several clips: OUT/results.png (gnuplot; default on)",
                 .names = "--plot,!--no-plot"});
    v("duration", t.duration,
      OptionMeta{.help = "seconds (default: the clip once)", .unit = "s", .min = 0});
    v("loop", t.loop, OptionMeta{.help = "repeat the clip, root carried forward"});
    v("first_frame", t.first_frame,
      OptionMeta{.help = "first frame of the range (default: after a leading T-pose)", .min = 0});
    v("last_frame", t.last_frame, OptionMeta{.help = "last frame (-1: the end)", .min = -1});
    v("map", t.map,
      OptionMeta{.help = "YAML joint map onto --model (default: found from its tree, written to "
                         "--out/map.yaml)"});
    v("model", t.model, OptionMeta{.help = "model file (MJCF, URDF, SKEL)"});
    v("engine", t.engine, OptionMeta{.help = "mujoco or dart"});
    v("threads", t.threads, OptionMeta{.help = "rollout threads (default: all cores)", .min = 0});
    v("scale_to_meters", t.scale_to_meters,
      OptionMeta{
          .help = "metres per file unit (default: detected from the legs)", .unit = "m", .min = 0});
    v("human_limits", t.human_limits,
      OptionMeta{.help =
                     "the clip's character gets a person's joint torques as its limits, clamped "
                     "(docs/mocap.md)"});
    v("sets", t.sets, OptionMeta{.help = "override: key.path=value", .names = "--set"});
    v("record", batch.record, OptionMeta{.help = "also render the run as an MP4"});
    v("camera", camera,
      OptionMeta{
          .help = "--record: side, front (of the clip's heading), follow or free (the scenario's "
                  "camera.*; default side)"});
    v("size", size, OptionMeta{.help = "--record: frame size WxH (default 640x360)"});
    v("debug_draw", debug_draw,
      OptionMeta{
          .help = "--record: on draws the COM, contacts, planner path and reference ghost (default "
                  "off)"});
    v("fps", fps,
      OptionMeta{.help = "--record: video frames per simulated second (default 30)", .min = 0});
    v("view", batch.view, OptionMeta{.help = "watch the tracking run in the viewer instead"});
    v("quit_after_s", quit_after_s,
      OptionMeta{.help = "--view: close after S s of wall time and print the pace",
                 .names = "--quit-after",
                 .unit = "s"});
    v("quiet", t.quiet, OptionMeta{.help = "no summary on stdout"});
    v("origin_centred", t.origin_centred,
      OptionMeta{
          .help = "tracked.bvh starts above the origin, on the ground (the default: where the clip "
                  "starts, to overlay it)"});
  }
};

}  // namespace stance
