# What pcl_pslam does with each bad input: one row an input, the files it is made of, the
# command, the exit status and (part of) the one error line. test/CMakeLists.txt runs each
# row as ctest `pcl_pslam.bad.NAME` (the status, the message, and for a run: no --out and
# nothing beside it afterwards); scripts/robustness_doc.cmake writes docs/robustness.md's
# table from the same rows, and ctest `pcl_pslam.robustness_doc` fails where the two differ.
#
# bad_input(NAME INPUT "what it is" [FILE path "content"]... [LINK path target]
#           [LIMIT blocks] [INTERRUPT seconds[:SIG]] [STDOUT file] EXIT status MESSAGE "text"
#           ARGS ...)
# In FILE, LINK and ARGS: @IN@ is the row's own input folder, @OUT@ its --out, @TINY@ six
# small scans of a corner (scan0..5.xyz), @SRC@ the test folder. Messages hold no ';'.

# Usage (exit 2): the command line, checked before anything is read.
bad_input(no_command INPUT "no command" EXIT 2 MESSAGE "no command" ARGS)
bad_input(unknown_option INPUT "an unknown option"
  EXIT 2 MESSAGE "unrecognised option '--frobnicate'" ARGS demo --frobnicate 1)
bad_input(bad_number INPUT "a number that is not one"
  EXIT 2 MESSAGE "the argument ('abc') for option '--reduce' is invalid"
  ARGS demo --voxel abc --out @OUT@)
bad_input(reduce_out_of_range INPUT "a length below its range (1e-6 to 1e9 in the files' units)"
  EXIT 2 MESSAGE "-r/--reduce takes 1e-06 to 1e+09 or 0, got 1e-09"
  ARGS run @TINY@ -r 1e-9 --out @OUT@)
bad_input(scale_out_of_range INPUT "--scale beyond 1e-6 to 1e6"
  EXIT 2 MESSAGE "--scale takes 1e-06 to 1e+06, got 1e+30" ARGS run @TINY@ --scale 1e30 --out @OUT@)
bad_input(threads_out_of_range INPUT "--threads above 1024"
  EXIT 2 MESSAGE "-t/--threads takes 0 to 1024, got 1025" ARGS run @TINY@ -t 1025 --out @OUT@)
bad_input(sweep_period_out_of_range INPUT "--sweep-period beyond 1e-4 to 3600 s"
  EXIT 2 MESSAGE "--sweep-period takes 0.0001 to 3600, got 5000"
  ARGS run @TINY@ --deskew --sweep-period 5000 --out @OUT@)
bad_input(negative_segment_size INPUT "a negative scan count (wrapped to 2^64 - 1 by the parser)"
  EXIT 2 MESSAGE "--segment-size takes 0 to 1e+08, got 1.84467e+19"
  ARGS run @TINY@ --segment-size -1 --out @OUT@)
bad_input(unknown_format INPUT "an unknown scan format"
  EXIT 2 MESSAGE "unknown scan format 'foo'" ARGS run -f foo @TINY@ --out @OUT@)
bad_input(poses_and_no_poses INPUT "--poses with --no-poses"
  EXIT 2 MESSAGE "--poses and --no-poses exclude each other"
  ARGS run @TINY@ --no-poses --poses @TINY@/scan0.xyz --out @OUT@)
bad_input(sweep_no_times INPUT "--sweep-period without time stamps"
  EXIT 2 MESSAGE "--sweep-period needs the scans' time stamps"
  ARGS run @TINY@ --deskew --sweep-period 0.1 -q --out @OUT@)
bad_input(simulate_unknown_format INPUT "`simulate` with an unknown --format"
  EXIT 2 MESSAGE "unknown --format 'las' (auto, uos, kitti, pcd)"
  ARGS simulate --preset office --format las @OUT@)
bad_input(simulate_one_beam INPUT "`simulate --beams 1`"
  EXIT 2 MESSAGE "--beams must be 0 (the preset's) or 2 to 4096, got 1"
  ARGS simulate --preset kitti --beams 1 @OUT@)
bad_input(simulate_too_many_beams INPUT "`simulate --beams 100000000` (a sweep of that many rows would not end)"
  EXIT 2 MESSAGE "--beams must be 0 (the preset's) or 2 to 4096, got 100000000"
  ARGS simulate --preset kitti --beams 100000000 @OUT@)
bad_input(simulate_threads_out_of_range INPUT "`simulate --threads` above 1024"
  EXIT 2 MESSAGE "--threads takes 0 (all cores) to 1024, got 5000"
  ARGS simulate --preset office -t 5000 @OUT@)
bad_input(option_value_placeholder INPUT "a value holding Boost's placeholder `%value%` (Boost 1.74's message substitutes it for ever)"
  EXIT 2 MESSAGE "the option '--start' or its value is invalid" ARGS run @TINY@ -s a%value% --out @OUT@)
bad_input(evaluate_value_placeholder INPUT "`evaluate` with a value holding `%value%`"
  EXIT 2 MESSAGE "the option '--delta' or its value is invalid" ARGS evaluate a b --delta %value%)
bad_input(simulate_value_placeholder INPUT "`simulate` with a value holding `%value%`"
  EXIT 2 MESSAGE "the option '--seed' or its value is invalid"
  ARGS simulate --preset office --seed %value% @OUT@)

# Paths (exit 2): checked before the work.
bad_input(missing_dir INPUT "a scan directory that does not exist"
  EXIT 2 MESSAGE "no_such_dir: no such directory" ARGS run @IN@/no_such_dir --out @OUT@)
bad_input(input_not_dir INPUT "a file for the scan directory"
  EXIT 2 MESSAGE "scan0.xyz: not a directory" ARGS run @TINY@/scan0.xyz -q --out @OUT@)
bad_input(link_loop INPUT "a scan directory that is a link loop"
  LINK loop loop EXIT 2 MESSAGE "loop: Too many levels of symbolic links" ARGS run @IN@/loop --out @OUT@)
bad_input(out_not_dir INPUT "an --out that is a file"
  EXIT 2 MESSAGE "CMakeLists.txt: exists and is not a directory"
  ARGS run @TINY@ --out @SRC@/CMakeLists.txt)
bad_input(out_is_input INPUT "--out the scan directory (its map.pcd would be the next run's scan)"
  FILE scan0.xyz "0 0 1\n1 0 1\n0 1 1\n" FILE scan1.xyz "0 0 1\n1 0 1\n0 1 1\n"
  EXIT 2 MESSAGE "holds what no run wrote (scan0.xyz, scan1.xyz)" ARGS run @IN@ -q --out @IN@/)
bad_input(out_holds_other_files INPUT "an --out holding files no run wrote (they would be mixed in, or lost)"
  FILE out/notes.md "mine\n"
  EXIT 2 MESSAGE "the output directory holds what no run wrote (notes.md)"
  ARGS run @TINY@ -q --out @IN@/out)
bad_input(log_with_poses INPUT "a 2D laser log with --poses (the log holds its odometry)"
  FILE log.clf "FLASER 3 1 1 1 0 0 0 0 0 0 1 h 1\nFLASER 3 1 1 1 1 0 0 1 0 0 2 h 2\n"
  EXIT 2 MESSAGE "log.clf: a CARMEN log holds its own odometry and time stamps"
  ARGS run @IN@/log.clf --poses @IN@/log.clf -q --out @OUT@)
bad_input(log_too_few_scans INPUT "a 2D laser log whose robot never moves (one scan kept)"
  FILE log.clf "FLASER 3 1 1 1 0 0 0 0 0 0 1 h 1\nFLASER 3 1 1 1 0 0 0 0 0 0 2 h 2\n"
  EXIT 2 MESSAGE "log.clf: 1 of its 2 selected laser scans"
  ARGS run @IN@/log.clf -q --out @OUT@)

# Data (exit 1): the message names the file (and line).
bad_input(no_scans INPUT "a directory without scan files"
  FILE notes.md "no scans here\n" EXIT 1 MESSAGE "no scan files" ARGS run @IN@ --out @OUT@)
bad_input(empty_scan INPUT "an empty scan file"
  FILE a.xyz "0 0 1\n1 0 1\n0 1 1\n" FILE b.xyz ""
  EXIT 1 MESSAGE "b.xyz: empty file (no points)" ARGS run @IN@ --out @OUT@)
bad_input(non_numeric INPUT "a text scan with a word for a number"
  FILE a.xyz "0 0 1\n1 0 1\n0 1 1\n" FILE b.xyz "0 0 1\nfoo bar baz\n"
  EXIT 1 MESSAGE "b.xyz:2: column 1 is not a number" ARGS run @IN@ --out @OUT@)
bad_input(bad_log_line INPUT "a 2D laser log with a line of too few fields"
  FILE log.clf "FLASER 3 1 1 1 0 0 0 0 0 0 1 h 1\nFLASER 3 1 1\n"
  EXIT 1 MESSAGE "log.clf:2: " ARGS run @IN@/log.clf -q --out @OUT@)
bad_input(no_finite_points INPUT "a scan of NaN points only"
  FILE a.xyz "0 0 1\n1 0 1\n0 1 1\n" FILE b.xyz "nan nan nan\n"
  EXIT 1 MESSAGE "b.xyz: no finite points" ARGS run @IN@ --out @OUT@)
bad_input(truncated_bin INPUT "a KITTI .bin not a multiple of 16 bytes"
  FILE a.bin "0123456789abcdef0123" FILE b.bin "0123456789abcdef0123456789abcdef"
  EXIT 1 MESSAGE "not a multiple of 16" ARGS run @IN@ --out @OUT@)
bad_input(scan_is_dir INPUT "a scan file that is a directory"
  FILE scan0.xyz "0 0 1\n1 0 1\n0 1 1\n" FILE scan1.xyz/x "" FILE scan2.xyz "0 0 1\n1 0 1\n0 1 1\n"
  EXIT 1 MESSAGE "scan1.xyz: not a regular file" ARGS run @IN@ -q --out @OUT@)
bad_input(poses_count INPUT "a poses file with more poses than scans"
  FILE poses.txt "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n"
  EXIT 1 MESSAGE "poses.txt: 7 poses for 6 .xyz scans"
  ARGS run @TINY@ --poses @IN@/poses.txt --out @OUT@)
bad_input(pose_not_rigid INPUT "a KITTI pose whose rotation is scaled (any 12 numbers parse)"
  FILE poses.txt "1 0 0 0 0 1 0 0 0 0 1 0\n2 0 0 0 0 2 0 0 0 0 2 0\n1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n"
  EXIT 1 MESSAGE "poses.txt: pose 2 is not a rigid motion"
  ARGS run @TINY@ --poses @IN@/poses.txt --out @OUT@)
bad_input(pose_far INPUT "a 3DTK .pose 1e300 cm away"
  FILE scan000.3d "0 0 100\n100 0 100\n0 100 100\n" FILE scan000.pose "0 0 0\n0 0 0\n"
  FILE scan001.3d "0 0 100\n100 0 100\n0 100 100\n" FILE scan001.pose "1e300 0 0\n0 0 0\n"
  EXIT 1 MESSAGE "scan001.pose: " ARGS run @IN@ --out @OUT@)
bad_input(pose_missing INPUT "`.pose` files beside some `.3d` scans, the first missing"
  FILE scan000.3d "0 0 100\n100 0 100\n0 100 100\n"
  FILE scan001.3d "0 0 100\n100 0 100\n0 100 100\n" FILE scan001.pose "0 0 0\n0 0 0\n"
  EXIT 1 MESSAGE "scan000.pose: missing" ARGS run @IN@ --out @OUT@)
bad_input(times_count INPUT "a times.txt beside the scans with another count"
  FILE a.xyz "0 0 1\n1 0 1\n0 1 1\n" FILE b.xyz "0 0 1\n1 0 1\n0 1 2\n" FILE times.txt "0.0\n0.1\n0.2\n"
  EXIT 1 MESSAGE "3 timestamps for 2 scans" ARGS run @IN@ --out @OUT@)
bad_input(bad_times INPUT "a times.txt line with a comma"
  FILE a.xyz "0 0 1\n1 0 1\n0 1 1\n" FILE b.xyz "0 0 1\n1 0 1\n0 1 2\n" FILE c.xyz "0 0 1\n1 0 1\n0 1 3\n"
  FILE times.txt "0.0\n0,1\n0.2\n"
  EXIT 1 MESSAGE "times.txt:2: expected 1 numbers" ARGS run @IN@ -q --out @OUT@)

# The run's end: a full disk, standard output, signals. --out stays as it was (absent). The
# tiny run's files: frames <= 456 bytes, poses.txt 1334, map.pcd 6780, map.png 26169,
# report.json 6150 (--map-voxel 2: map.pcd 1992, report.json 6028); each LIMIT (512-byte
# blocks, writes beyond fail with EFBIG) lies between its neighbours.
bad_input(full_disk_frames INPUT "a full disk at the first .frames file"
  LIMIT 0 EXIT 1 MESSAGE "full_disk_frames/scan000.frames: write error"
  ARGS run @TINY@ -q --out @OUT@)
bad_input(full_disk_poses INPUT "a full disk at poses.txt"
  LIMIT 2 EXIT 1 MESSAGE "full_disk_poses/poses.txt: write error" ARGS run @TINY@ -q --out @OUT@)
bad_input(full_disk_map INPUT "a full disk at map.pcd"
  LIMIT 8 EXIT 1 MESSAGE "full_disk_map/map.pcd: write error" ARGS run @TINY@ -q --out @OUT@)
bad_input(full_disk_picture INPUT "a full disk at map.png"
  LIMIT 38 EXIT 1 MESSAGE "full_disk_picture/map.png: cannot write" ARGS run @TINY@ -q --out @OUT@)
bad_input(full_disk_report INPUT "a full disk at report.json"
  LIMIT 6 EXIT 1 MESSAGE "full_disk_report/report.json: write error"
  ARGS run @TINY@ -q --no-picture --map-voxel 2 --out @OUT@)
bad_input(full_disk_simulate INPUT "a full disk at `simulate`'s first scan"
  LIMIT 64 EXIT 1 MESSAGE "full_disk_simulate/scan000.3d: write failed"
  ARGS simulate --preset office @OUT@)
bad_input(full_stdout INPUT "standard output to /dev/full"
  FILE a.txt "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n"
  STDOUT /dev/full EXIT 1 MESSAGE "standard output: write error"
  ARGS evaluate @IN@/a.txt @IN@/a.txt --align none)
bad_input(interrupt INPUT "SIGINT during the run"
  INTERRUPT 3 EXIT 130 MESSAGE "interrupted (SIGINT)" ARGS demo --preset hannover -q --out @OUT@)
bad_input(hangup INPUT "SIGHUP (the terminal closed) during the run"
  INTERRUPT 3:HUP EXIT 129 MESSAGE "hung up (SIGHUP)" ARGS demo --preset hannover -q --out @OUT@)

# `evaluate`.
bad_input(evaluate_missing INPUT "`evaluate` of a file that does not exist"
  EXIT 2 MESSAGE "no such file or directory" ARGS evaluate @IN@/none.txt @IN@/none.txt)
bad_input(evaluate_no_pair INPUT "`evaluate --delta` as long as the trajectory (no pose pair)"
  FILE a.txt "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n1 0 0 2 0 1 0 0 0 0 1 0\n"
  EXIT 1 MESSAGE "has no pose pair in 3 poses" ARGS evaluate @IN@/a.txt @IN@/a.txt --delta 3 --align none)
bad_input(evaluate_negative_delta INPUT "`evaluate --delta -1`"
  FILE a.txt "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n"
  EXIT 2 MESSAGE "take a frame count from 1 to 1e9" ARGS evaluate @IN@/a.txt @IN@/a.txt --delta -1)
bad_input(evaluate_relations_no_match INPUT "`evaluate --relations` whose times match none of the estimate's"
  FILE a.tum "0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n" FILE r.relations "5 6 1 0 0 0 0 0\n"
  EXIT 1 MESSAGE "has both its times among" ARGS evaluate @IN@/a.tum --relations @IN@/r.relations)
bad_input(evaluate_relations_and_truth INPUT "`evaluate --relations` with a GROUND_TRUTH too"
  FILE a.tum "0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n" FILE r.relations "0 1 1 0 0 0 0 0\n"
  EXIT 2 MESSAGE "--relations FILE needs ESTIMATE and no GROUND_TRUTH"
  ARGS evaluate @IN@/a.tum @IN@/a.tum --relations @IN@/r.relations)
