/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "arguments.h"
#include "options.h"

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/parallel.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iterator>
#include <sstream>
#include <typeinfo>

namespace po = boost::program_options;

namespace pcl_pslam {

namespace {

/** ASCII lower case (axis and style names). */
std::string
lowerCase(std::string s)
{
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return s;
}

/** The option groups; `o` receives the values (notify). Texts give unit and default;
 *  3DTK slam6D's names (src/slam6d/slam6D.cc usage()) where the meaning is the same. */
struct Descriptions {
  po::options_description input{"Input (run)"};
  po::options_description pipeline{"Matching and loop closing (lengths in the files' units; "
                                   "defaults in metres)"};
  po::options_description output{"Output"};
  po::options_description general{"General"};
  po::options_description hidden;

  explicit Descriptions(Options& o)
  {
    addInput(o);
    addPipeline(o);
    addOutputAndGeneral(o);
  }

  void
  addInput(Options& o)
  {
    // clang-format off
    input.add_options()
      ("format,f", po::value<std::string>(&o.format)->value_name("F"),
       "scan format: uos (3DTK .3d, cm, with .pose odometry), pcd, ply, xyz, txt, bin "
       "(KITTI/velodyne). Default: the most common scan extension in DIR")
      ("start,s", po::value<int>(&o.first)->value_name("NR"),
       "start at scan NR (3DTK: counting starts with 0; the number in the file name when "
       "every file has one, else the position in name order) [default 0]")
      ("end,e", po::value<int>(&o.last)->value_name("NR"),
       "end after scan NR (inclusive; past the last scan: the last) [default: all]")
      ("max,max-range,m", po::value<double>(&o.max_range)->value_name("NR"),
       "drop points farther than NR from the scanner, files' units (also --max-range); "
       "the local map reaches as far [default: none; map: 5 x the median range]")
      ("min,min-range,M", po::value<double>(&o.min_range)->value_name("NR"),
       "drop points closer than NR to the scanner, files' units (also --min-range) [default 0]")
      ("poses", po::value<std::string>(&o.poses_file)->value_name("FILE"),
       "initial poses, KITTI (12 numbers a line) or TUM (timestamp tx ty tz qx qy qz qw: "
       "its stamps are the scans' unless --times or times.txt give them), one line per "
       "scan file in DIR, files' units, the scanner's frame (KITTI's poses.txt is the "
       "left camera's). Default: odometry.txt in DIR (as `simulate` writes it), else "
       ".pose files beside .3d scans, else none (constant velocity; --no-poses)")
      ("times", po::value<std::string>(&o.times_file)->value_name("FILE"),
       "one timestamp (s) per scan file in DIR, for poses_tum.txt [default: times.txt in DIR "
       "or its parent, else a TUM --poses file's stamps, else each scan's number as -s/-e "
       "count it]")
      ("scale", po::value<double>()->value_name("S"),
       "coordinates times S are metres [default 1; uos: 0.01]")
      ("up", po::value<std::string>()->value_name("x|y|z"),
       "the vertical axis [default z; uos: y]")
      ("min-travel", po::value<double>(&o.min_travel)->value_name("M"),
       "a 2D log: keep a scan where the odometry moved M m or turned --min-turn [default 0.2]")
      ("min-turn", po::value<double>()->value_name("DEG"), "see --min-travel [default 10]");
    // clang-format on
  }

  void
  addPipeline(Options& o)
  {
    const pcl_parallel::slam::Parameters d;
    auto text = [](const std::string& s) { return s; };
    // clang-format off
    pipeline.add_options()
      ("reduce,voxel,r", po::value<double>()->value_name("NR"),
       "voxel size of the reduction (one centroid per voxel) before matching (also "
       "--voxel) [default: auto, the scans' median range / 20]")
      ("iter,icp-iterations,i", po::value<int>(&o.icp_iterations)->value_name("NR"),
       text("maximal number of ICP iterations (also --icp-iterations) [default " +
            std::to_string(d.matcher.max_iterations) + "]").c_str())
      ("dist,icp-distance,d", po::value<double>()->value_name("NR"),
       "maximal point-to-point distance for matching with ICP (also --icp-distance) "
       "[default: auto, 10 voxels]")
      ("iterSLAM,lum-iterations,I", po::value<int>(&o.lum_iterations)->value_name("NR"),
       text("maximal number of pLUM (SLAM) iterations per relaxation, >= 1 (also "
            "--lum-iterations) [default " + std::to_string(d.loops.lum_iterations) +
            "; 3DTK's default 0 skips SLAM: here --no-loops]").c_str())
      ("icp-final", po::value<double>()->value_name("NR"),
       "after converging within -d, the front end's match is refined within NR (coarse to "
       "fine; NR >= -d: no refinement) [default: auto, 2 voxels]")
      ("distSLAM,lum-distance,D", po::value<double>()->value_name("NR"),
       "maximal point-to-point distance for matching with pLUM, first iteration (also "
       "--lum-distance) [default: auto, 10 voxels]")
      ("lum-final", po::value<double>()->value_name("NR"),
       "pLUM's distance shrinks by x0.7 per iteration down to NR [default: auto, 2 voxels]")
      ("cldist,loop-distance,c", po::value<double>()->value_name("NR"),
       "maximal distance of two scan poses for a closed loop (also --loop-distance) "
       "[default: auto, the scans' median range]")
      ("loopsize,loop-size,l", po::value<int>(&o.loop_size)->value_name("NR"),
       text("a loop must exceed NR scans (also --loop-size) [default " +
            std::to_string(d.loops.min_separation) + "]").c_str())
      ("epsICP", po::value<double>()->value_name("NR"),
       "stop pICP when the transform changes by less than NR (squared: PCL's "
       "transformation epsilon) [default 1e-8]")
      ("epsSLAM", po::value<double>()->value_name("NR"),
       "stop pLUM when the mean pose update (m, rad) is below NR [default: auto, a voxel / 100]")
      ("metascan", po::bool_switch(&o.metascan),
       "match each scan against a map of the previous scans (the default here: a local "
       "map of the recent scans)")
      ("scan-to-scan", po::bool_switch(&o.scan_to_scan),
       "match each scan against its predecessor only (the paper's and slam6D's default)")
      ("deskew", po::bool_switch(&o.deskew),
       "deskew scans taken while moving (spinning LiDAR) by the predicted motion, "
       "assuming consecutive sweeps; for keyframes add --sweep-period. Each point's time "
       "in the sweep comes from a PCD/PLY time field (t, time, timestamp, time_stamp, "
       "offset_time) when the scan has one, else from its azimuth")
      ("sweep-period", po::value<double>()->value_name("SEC"),
       "with --deskew: one sweep takes SEC seconds (0.1 for a 10 Hz LiDAR), so keyframes "
       "seconds apart are deskewed by one sweep's share of the step; needs time stamps "
       "(--times or times.txt) [default: none, consecutive sweeps]")
      ("sweep-ccw", po::bool_switch(&o.sweep_ccw),
       "with --deskew: the head turns counter-clockwise seen from +z in the scans' frame "
       "[default: clockwise from facing -x, as KITTI's Velodyne]")
      ("map-normals", po::bool_switch(&o.map_normals),
       "point-to-plane normals from the local map instead of each scan (sparse scanners, "
       "e.g. Livox, and always for 2D scans; slower on large maps)")
      ("loop6DAlgo,L", po::value<int>(&o.elch)->value_name("NR"),
       "3DTK's loop closing before pLUM: 0 none, 1-4 ELCH (a loop's error spread along "
       "it by path length; 3DTK's 4, SLERP) [default 4]")
      ("no-sequence-constraints", po::bool_switch(&o.no_sequence_constraints),
       "pLUM without the front end's matches as constraints between consecutive scans "
       "(only the scan pairs' links, as the paper)")
      ("no-pose-search", po::bool_switch(&o.no_pose_search),
       "without initial poses, never search a scan's pose over all headings and "
       "translations (by default searched where a match to the previous scan looks wrong: "
       "stop-and-go scanners carried between stations)")
      ("no-poses", po::bool_switch(&o.no_poses),
       "no initial poses even where the scans have them (.pose files, odometry.txt in DIR; "
       "demo: the simulated odometry): constant-velocity guesses, as without any")
      ("no-loops", po::bool_switch(&o.no_loops), "no loop closing (front end only)");
    // clang-format on
  }

  void
  addOutputAndGeneral(Options& o)
  {
    // clang-format off
    output.add_options()
      ("out,o", po::value<std::string>(&o.out)->value_name("DIR"),
       "where outputs go: absent, empty or an earlier run's (replaced at the end); checked "
       "before any work [default pcl_pslam_out]")
      ("ply", po::bool_switch(&o.ply), "also write the map as map.ply")
      ("map-voxel", po::value<double>()->value_name("NR"),
       "voxel size of map.pcd/map.ply [default: -r when given, else 0.1 m]")
      ("no-picture", "do not write map.png")
      ("style", po::value<std::string>(&o.style)->value_name("S"),
       "map.png: height (colour = height above the trajectory), floorplan (walls dark), "
       "occupancy (2D: the scans' rays), auto (2D: occupancy; floorplan when most poses "
       "see a ceiling) [default auto]");
    general.add_options()
      ("preset", po::value<std::string>(&o.preset)->value_name("NAME"),
       "demo: the simulated preset to map (pcl_pslam simulate --list) [default office]")
      ("keep", po::value<std::string>(&o.keep)->value_name("DIR"),
       "demo: write the simulated scans to DIR and keep them [default: a temporary folder]")
      ("threads,t", po::value<unsigned>(&o.threads)->value_name("N"),
       "threads, 0 = all cores [default 0]")
      ("segment-size", po::value<std::size_t>()->value_name("NR"),
       "match the sequence in segments of NR scans, each with a front end of its own "
       "(spread over the ranks under mpirun), then close loops over the whole; the poses "
       "are the same for any number of ranks [default: one segment per rank under mpirun, "
       "else 0 = one front end]")
      ("segment-overlap", po::value<std::size_t>(&o.segment_overlap)->value_name("NR"),
       "scans a segment's front end matches before its own first scan, shared with the "
       "previous segment [default 5]")
      ("quiet,q", po::bool_switch(&o.quiet), "no progress, only errors and the summary")
      ("help,h", po::bool_switch(&o.help), "this help");
    hidden.add_options()
      ("dir", po::value<std::string>(&o.dir), "scan directory");
    // clang-format on
  }
};

/** A numeric option's stated range: [lo, hi], and with zero_ok 0 too. */
struct Range {
  const char* name;  ///< the option's long name
  const char* shown; ///< as messages and --help name it
  double lo, hi;
  bool zero_ok = false;
};
constexpr double kMaxCount = 2147483647.0; // int's
/** Every numeric option's range, for the checks and --help alike. Lengths are in the files'
 *  units: beyond 1e-6 to 1e9 the voxel grids' integer keys (2^31 voxels an axis) or float's
 *  7 digits end before the scans do. */
// clang-format off
constexpr Range kRanges[] = {
    {"max", "-m/--max", 1e-6, 1e9},           {"min", "-M/--min", 1e-6, 1e9, true},
    {"scale", "--scale", 1e-6, 1e6},          {"sweep-period", "--sweep-period", 1e-4, 3600.0},
    {"reduce", "-r/--reduce", 1e-6, 1e9, true}, {"dist", "-d/--dist", 1e-6, 1e9},
    {"icp-final", "--icp-final", 1e-6, 1e9},  {"distSLAM", "-D/--distSLAM", 1e-6, 1e9},
    {"lum-final", "--lum-final", 1e-6, 1e9},  {"cldist", "-c/--cldist", 1e-6, 1e9, true},
    {"map-voxel", "--map-voxel", 1e-6, 1e9, true}, {"epsICP", "--epsICP", 1e-30, 1.0},
    {"epsSLAM", "--epsSLAM", 1e-30, 1.0},     {"start", "-s/--start", 0.0, kMaxCount},
    {"iter", "-i/--iter", 1.0, kMaxCount},    {"iterSLAM", "-I/--iterSLAM", 1.0, kMaxCount},
    {"loopsize", "-l/--loopsize", 1.0, kMaxCount}, {"loop6DAlgo", "-L/--loop6DAlgo", 0.0, 4.0},
    {"threads", "-t/--threads", 0.0, pcl_parallel::kMaxThreads},
    {"segment-size", "--segment-size", 0.0, 1e8},
    {"segment-overlap", "--segment-overlap", 1.0, 1e5},
    {"min-travel", "--min-travel", 1e-6, 1e9, true}, {"min-turn", "--min-turn", 1e-6, 360.0, true}};
// clang-format on

/** "LO to HI[ or 0]" (HI at int's end: "LO or more"). */
std::string
rangeText(const Range& r)
{
  std::ostringstream s;
  s << r.lo;
  if (r.hi >= kMaxCount)
    s << " or more";
  else
    s << " to " << r.hi << (r.zero_ok ? " or 0" : "");
  return s.str();
}

/** Every numeric option given, checked against its range (exit 2 naming it). A negative
 *  count, which the parser wraps to a huge unsigned, is out of range too. */
void
checkRanges(const po::variables_map& vm)
{
  for (const Range& r : kRanges) {
    if (!vm.count(r.name))
      continue;
    const boost::any& any = vm[r.name].value();
    const double v = any.type() == typeid(double)     ? boost::any_cast<double>(any)
                     : any.type() == typeid(int)      ? boost::any_cast<int>(any)
                     : any.type() == typeid(unsigned) ? boost::any_cast<unsigned>(any)
                                                      : boost::any_cast<std::size_t>(any);
    if (!(v >= r.lo && v <= r.hi) && !(r.zero_ok && v == 0.0)) {
      std::ostringstream msg;
      msg << r.shown << " takes " << rangeText(r) << ", got " << v;
      throw UsageError(msg.str());
    }
  }
}

/** A length or number option where given (checked by checkRanges). */
std::optional<double>
given(const po::variables_map& vm, const char* name)
{
  return vm.count(name) ? std::optional<double>(vm[name].as<double>()) : std::nullopt;
}

} // namespace

std::string
helpText(const std::string& command)
{
  std::ostringstream s;
  if (command != "run" && command != "demo") {
    s << "usage: pcl_pslam demo [options]        map the built-in simulated scan set\n"
         "       pcl_pslam run [options] DIR      map the scans in DIR (name order)\n"
         "       pcl_pslam simulate ...           simulated scan sets (presets)\n"
         "       pcl_pslam evaluate ...           ATE / RPE of pose files\n"
         "       pcl_pslam COMMAND --help         the options of COMMAND\n"
         "\n"
         "Exit status: 0 done, 1 bad data (a scan, a poses file; the message names the\n"
         "file and line), 2 bad usage (unknown option or format, a path on the command\n"
         "line that does not exist, an --out that cannot be used), 128 + the signal when\n"
         "interrupted (130 SIGINT, 143 SIGTERM, 129 SIGHUP: --out as it was).\n";
    return s.str();
  }
  Options o;
  Descriptions d(o);
  if (command == "run")
    s << "usage: pcl_pslam run [options] DIR\n\n"
         "DIR holds one file per scan; the scans are matched in name order, numbered names\n"
         "by their numbers (scan2 before scan10, as 3DTK's scanNNN). DIR may also be a 2D\n"
         "laser log (CARMEN .clf or .clf.bz2), mapped in the plane. 3DTK slam6D's\n"
         "option names work with their meaning, so a slam6D command line such as\n"
         "  pcl_pslam run -s 0 -e 65 -r 10 -i 100 -d 75 -D 250 -I 50 --cldist 750 -f uos dat\n"
         "runs unchanged: lengths on the command line are in the files' units (uos: cm)\n"
         "and scaled with the data; the defaults are given in metres.\n\n"
      << d.input << "\n";
  else
    s << "usage: pcl_pslam demo [options]\n\n"
         "Simulates a preset (--preset, office by default: 11 stop-and-go scans of an office\n"
         "floor with drifting odometry), maps it as `run` would and prints the pose errors\n"
         "against the simulation's truth. Lengths in metres.\n\n";
  s << d.pipeline << "\n"
    << d.output << "\n"
    << d.general << "\n"
    << "Outputs (written into a temporary directory beside --out and swapped in at the end:\n"
       "--out holds one run's outputs, an earlier run's replaced, or is as it was):\n"
       "scanNNN.frames\n"
       "(3DTK, per scan: initial, ICP and final pose, 4x4 column-major + type code; uos\n"
       "data in 3DTK's units), poses.txt / poses_icp.txt (KITTI), poses_tum.txt /\n"
       "poses_icp_tum.txt (TUM: time x y z qx qy qz qw), graph.g2o (2D: the pose graph),\n"
       "map.pcd, map.ply (--ply), map.png, report.json (parameters, per-scan numbers).\n\n"
    << "Ranges (out of range: exit 2 naming the option; lengths in the files' units):\n";
  std::string line;
  for (const Range& r : kRanges) {
    const std::string item = std::string(r.shown) + ' ' + rangeText(r) +
                             (&r == &kRanges[std::size(kRanges) - 1] ? "." : ";");
    if (line.size() + item.size() > 86)
      s << line << '\n', line.clear();
    line += (line.empty() ? "" : " ") + item;
  }
  s << line << " -e >= -s.\n";
  return s.str();
}

namespace {

/** The options of `run` / `demo` after the command, parsed into `o` (Boost). */
po::variables_map
parseOptions(Options& o, int argc, const char* const* argv)
{
  Descriptions d(o);
  po::options_description all;
  all.add(d.pipeline).add(d.output).add(d.general);
  if (o.command == "run")
    all.add(d.input).add(d.hidden);
  po::positional_options_description positional;
  positional.add("dir", 1);
  const std::vector<std::string> args(argv + 2, argv + argc);
  try {
    return parseArguments(args, all, positional);
  }
  catch (const po::error& e) {
    std::string what = optionErrorMessage(e, args);
    if (what.find("too many positional") != std::string::npos)
      what = o.command == "run" ? "run takes one directory" : "demo takes no directory";
    throw UsageError(o.command + ": " + what);
  }
}

/** Checks and converts the input options (format, selection, ranges, units, sweeps). */
void
checkInputOptions(Options& o, const po::variables_map& vm)
{
  if (vm.count("format")) {
    const std::string f = pcl_parallel::io::scanFormatFromName(o.format);
    if (f.empty())
      throw UsageError("--format: unknown scan format '" + o.format +
                       "' (uos, pcd, ply, xyz, txt, bin)");
    o.format = f;
  }
  checkRanges(vm);
  if (vm.count("end") && (o.last < 0 || o.last < o.first))
    throw UsageError("-e/--end must be >= -s/--start (" + std::to_string(o.first) + ")");
  if (o.min_range >= o.max_range)
    throw UsageError("-M/--min must be smaller than -m/--max");
  o.scale = given(vm, "scale");
  if (vm.count("up")) {
    const std::string axis = lowerCase(vm["up"].as<std::string>());
    if (axis != "x" && axis != "y" && axis != "z")
      throw UsageError("--up needs x, y or z, got '" + axis + "'");
    o.up = axis[0] - 'x';
  }
  if (o.sweep_ccw && !o.deskew)
    throw UsageError("--sweep-ccw needs --deskew");
  if (vm.count("min-turn"))
    o.min_turn = vm["min-turn"].as<double>() * M_PI / 180.0;
  if (vm.count("sweep-period")) {
    o.sweep_period = *given(vm, "sweep-period");
    if (!o.deskew)
      throw UsageError("--sweep-period needs --deskew");
  }
}

/** Checks and converts the pipeline's options (lengths, iterations, loops, threads). */
void
checkPipelineOptions(Options& o, const po::variables_map& vm)
{
  o.voxel = given(vm, "reduce");
  o.icp_distance = given(vm, "dist");
  o.icp_final = given(vm, "icp-final");
  o.lum_distance = given(vm, "distSLAM");
  o.lum_final = given(vm, "lum-final");
  o.loop_distance = given(vm, "cldist");
  if (o.metascan && o.scan_to_scan)
    throw UsageError("--metascan and --scan-to-scan exclude each other");
  if (o.no_poses && !o.poses_file.empty())
    throw UsageError("--poses and --no-poses exclude each other");
  o.map_voxel = given(vm, "map-voxel");
  o.eps_icp = given(vm, "epsICP");
  o.eps_slam = given(vm, "epsSLAM");
  if (vm.count("segment-size"))
    o.segment_size = vm["segment-size"].as<std::size_t>();
}

/** Checks the output options. */
void
checkOutputOptions(Options& o, const po::variables_map& vm)
{
  o.picture = vm.count("no-picture") == 0;
  o.style = lowerCase(o.style);
  if (const char* s[] = {"auto", "height", "floorplan", "occupancy"};
      std::find(std::begin(s), std::end(s), o.style) == std::end(s))
    throw UsageError("--style needs auto, height, floorplan or occupancy, got '" + o.style +
                     "'");
  if (o.out.empty())
    throw UsageError("--out: empty directory name");
}

} // namespace

Options
parseCommandLine(int argc, const char* const* argv)
{
  Options o;
  if (argc < 2)
    throw UsageError("no command (demo, run, simulate, evaluate; --help for the options)");
  o.command = argv[1];
  if (o.command == "--help" || o.command == "-h" || o.command == "help") {
    o.command.clear();
    o.help = true;
    return o;
  }
  if (o.command == "simulate" || o.command == "evaluate") { // their parsers take the rest
    o.rest.assign(argv + 2, argv + argc);
    return o;
  }
  if (o.command != "run" && o.command != "demo")
    throw UsageError("unknown command '" + o.command +
                     "' (demo, run, simulate, evaluate; --help for the options)");

  const po::variables_map vm = parseOptions(o, argc, argv);
  if (o.help)
    return o;
  if (o.command == "run" && o.dir.empty())
    throw UsageError("run: no scan directory given");
  checkInputOptions(o, vm);
  checkPipelineOptions(o, vm);
  checkOutputOptions(o, vm);
  return o;
}

pcl_parallel::slam::Parameters
toParameters(const Options& o, double scale)
{
  namespace slam = pcl_parallel::slam;
  slam::Parameters p;
  auto length = [scale](const std::optional<double>& v) { return v ? *v * scale : 0.0; };
  // The scans are cropped when read; the pipeline also sizes its local map by the range.
  p.reduction.min_range = o.min_range * scale;
  p.reduction.max_range = o.max_range * scale;
  p.reduction.voxel_size = length(o.voxel);
  p.deskew.enabled = o.deskew;
  p.deskew.sweep_period = o.sweep_period;
  p.deskew.sweep_clockwise = !o.sweep_ccw;
  slam::MatcherParameters& m = p.matcher;
  m.target = o.scan_to_scan ? slam::MatchTarget::kPreviousScan : slam::MatchTarget::kLocalMap;
  m.max_correspondence_distance = length(o.icp_distance);
  m.final_correspondence_distance = length(o.icp_final);
  m.max_iterations = o.icp_iterations;
  m.transformation_epsilon = o.eps_icp.value_or(m.transformation_epsilon);
  m.normals_from_map = o.map_normals;
  p.guess.pose_search = !o.no_pose_search;
  slam::LoopClosureParameters& l = p.loops;
  l.enabled = !o.no_loops;
  l.distance = length(o.loop_distance);
  l.min_separation = o.loop_size;
  l.distribute_error = o.elch != 0;
  l.lum_distance = length(o.lum_distance);
  l.lum_final_distance = length(o.lum_final);
  l.lum_iterations = o.lum_iterations;
  l.lum_epsilon = o.eps_slam.value_or(l.lum_epsilon);
  l.sequence_constraints = !o.no_sequence_constraints;
  p.num_threads = o.threads;
  return p;
}

pcl_parallel::slam::MappingOptions
toMappingOptions(const Options& o, int ranks)
{
  namespace slam = pcl_parallel::slam;
  slam::MappingOptions m;
  m.segment_size = o.segment_size.value_or(0);
  m.segment_overlap = o.segment_overlap;
  m.backend = ranks > 1            ? slam::MappingBackend::kRanks
              : m.segment_size > 0 ? slam::MappingBackend::kSegments
                                   : slam::MappingBackend::kOnline;
  return m;
}

double
mapVoxel(const Options& o, double scale)
{
  if (o.map_voxel)
    return *o.map_voxel * scale;
  return o.voxel ? *o.voxel * scale : 0.1; // the automatic voxel is the pipeline's own
}

} // namespace pcl_pslam
