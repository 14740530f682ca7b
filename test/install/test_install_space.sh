#!/usr/bin/env bash
# The install space, as a user of `catkin_make install` gets it: installs the built workspace, staged into a
# temporary directory (DESTDIR=... cmake --install: the install rules of CMakeLists.txt and catkin's relocatable
# setup files, without rebuilding), then, in a clean environment that sources only that install space (its
# local_setup.bash: setup.bash would chain the devel space that scripts/test sources before configuring; no devel
# space, no source tree on any path), checks that:
#   - every installed executable finds its libraries and answers --help;
#   - calibrate_lines calibrates the installed example and lands close to its truth;
#   - the installed calibration_node starts from the installed launch file and answers ~status and ~save (the
#     latter is a std_srvs/Trigger: python3-std-srvs must be installed for rosservice), offers the ~calibrate
#     action, publishes /diagnostics and the latched ~survey_status;
#   - calibration_node exits non-zero on a FATAL configuration error (no ~cameras);
#   - sim_time_guard deletes /use_sim_time when it stops.
# Usage: test_install_space.sh BUILD_DIR RESULT.xml   (writes a JUnit file; exit status non-zero on any failure)
set -uo pipefail
build_dir="$(cd "$1" && pwd)"
mkdir -p "$(dirname "$2")"
result_xml="$(cd "$(dirname "$2")" && pwd)/$(basename "$2")"
tmp="$(mktemp -d /tmp/insitu_install.XXXXXX)"
stage="$tmp/stage"
cases=()
failures=0

xml_escape() { sed -e 's/&/\&amp;/g' -e 's/</\&lt;/g' -e 's/>/\&gt;/g' -e 's/"/\&quot;/g' | tr -cd '\11\12\15\40-\176'; }

# record NAME STATUS OUTPUT_FILE
record() {
  local name="$1" status="$2" out="$3"
  if [ "$status" -eq 0 ]; then
    echo "[ OK ] $name"
    cases+=("<testcase classname=\"install_space\" name=\"$name\"/>")
  else
    echo "[FAIL] $name (status $status)"
    tail -n 40 "$out" | sed 's/^/       /'
    failures=$((failures + 1))
    cases+=("<testcase classname=\"install_space\" name=\"$name\"><failure message=\"status $status\">$(tail -n 40 "$out" | xml_escape)</failure></testcase>")
  fi
}

exec_env() { timeout 180 "$@"; }  # a check that hangs fails instead
# In a clean environment: only the install space's local_setup.bash, a private ROS_HOME and HOME, cwd $tmp.
clean_env() {
  cd "$tmp" || return 1
  exec_env env -i HOME="$tmp/home" ROS_HOME="$tmp/home/.ros" PATH=/usr/bin:/bin LANG=C.UTF-8 \
    ROS_MASTER_URI="http://127.0.0.1:$port" ROS_IP=127.0.0.1 \
    bash --noprofile --norc -c "source '$prefix/local_setup.bash' && $1"
}

# check NAME 'COMMAND' (run in the clean environment)
check() {
  local name="$1" cmd="$2" out="$tmp/$1.log"
  clean_env "$cmd" >"$out" 2>&1
  record "$name" $? "$out"
}

finish() {
  # SIGTERM: background jobs of a script ignore SIGINT.
  [ -n "${node_pid:-}" ] && kill -TERM "$node_pid" 2>/dev/null && wait "$node_pid" 2>/dev/null
  [ -n "${roscore_pid:-}" ] && kill -TERM "$roscore_pid" 2>/dev/null && wait "$roscore_pid" 2>/dev/null
  mkdir -p "$(dirname "$result_xml")"
  {
    echo '<?xml version="1.0" encoding="UTF-8"?>'
    echo "<testsuite name=\"install_space\" tests=\"${#cases[@]}\" failures=\"$failures\" errors=\"0\">"
    printf '%s\n' "${cases[@]}"
    echo '</testsuite>'
  } >"$result_xml"
  [ "$failures" -eq 0 ] && rm -rf "$tmp"
  echo "install space: ${#cases[@]} checks, $failures failed$([ "$failures" -eq 0 ] || echo " (logs in $tmp)")"
}
trap finish EXIT

mkdir -p "$tmp/home/.ros"
port=$((20000 + RANDOM % 20000))

install_prefix="$(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' "$build_dir/CMakeCache.txt")"
prefix="$stage$install_prefix"
out="$tmp/cmake_install.log"
DESTDIR="$stage" cmake --install "$build_dir" >"$out" 2>&1
status=$?
[ -f "$prefix/setup.bash" ] || { echo "no $prefix/setup.bash" >>"$out"; status=1; }
record cmake_install "$status" "$out"
[ "$status" -eq 0 ] || exit 1

share="$prefix/share/insitu_calibration"
bin="$prefix/lib/insitu_calibration"
# The package resolves to the install space, and nothing of the build or source tree is on any path.
check package_found "test \"\$(rospack find insitu_calibration)\" = '$share' && ! env | grep -e '$build_dir' -e /devel"
for f in LICENSE README.md package.xml launch/calibration_node.launch launch/calibrate_bag.launch \
  config/cameras.yaml config/calibration.rviz msg/CameraStatus.msg msg/SurveyStatus.msg srv/Calibrate.srv \
  action/Calibrate.action; do
  [ -f "$share/$f" ] || { echo "missing $share/$f" >"$tmp/missing.log"; record "installed_$(basename "$f")" 1 "$tmp/missing.log"; }
done
for exe in "$bin"/*; do
  name="$(basename "$exe")"
  [ -x "$exe" ] || continue
  case "$name" in
    plot_accuracy.py) continue ;;  # a plotting script, run by bench_accuracy
    sim_time_guard) check "help_$name" "'$exe' --help" ;;
    *) check "help_$name" "! ldd '$exe' | grep 'not found' && '$exe' --help" ;;
  esac
done

# A real example: the bundled correspondences, calibrated and compared with their truth.
check calibrate_lines_example "cd '$tmp' && calibrate() { rosrun insitu_calibration calibrate_lines \
  '$share/config/examples/lobby_cam_lines.yaml' --output '$tmp/lobby_cam.yaml' \
  --truth '$share/config/examples/lobby_cam_truth.yaml'; } && calibrate | tee '$tmp/lobby.txt' && \
  test -s '$tmp/lobby_cam.yaml' && \
  awk '/focal error/ {f=(\$3<0?-\$3:\$3)} /rotation error/ {r=\$3} /position error/ {p=\$3} \
       END {exit !(f < 0.1 && r < 0.2 && p < 5)}' '$tmp/lobby.txt'"

# The node: a master of our own (a random port), the installed launch file, its services.
(exec_env() { exec "$@"; } && clean_env "exec roscore -p $port") >"$tmp/roscore.log" 2>&1 &
roscore_pid=$!
check master_up "for i in \$(seq 60); do rostopic list >/dev/null 2>&1 && exit 0; sleep 0.5; done; exit 1"
(exec_env() { exec "$@"; } && clean_env "exec roslaunch --wait insitu_calibration calibration_node.launch \
  output_directory:='$tmp/calibrations'") >"$tmp/calibration_node.log" 2>&1 &
node_pid=$!
check node_status "for i in \$(seq 120); do rosservice list 2>/dev/null | grep -q /calibration_node/status && break; \
  sleep 0.5; done; rosservice call /calibration_node/status \"camera: ''\" | tee /dev/stderr | grep -q 'success: True'"
check node_save "rosservice call /calibration_node/save '{}' | tee /dev/stderr | grep -q 'calibration(s) saved'"
check node_action "rostopic list | grep -q /calibration_node/calibrate/goal && rosmsg show insitu_calibration/CalibrateFeedback"
check node_diagnostics "timeout 20 rostopic echo -n 1 /diagnostics | tee /dev/stderr | grep -q 'calibration_node: camera cam_east'"
check node_survey_status "timeout 20 rostopic echo -n 1 /calibration_node/survey_status | tee /dev/stderr | grep -q 'camera_name: \"cam_desk\"'"
kill -TERM "$node_pid" 2>/dev/null
wait "$node_pid" 2>/dev/null
node_pid=
# No ~cameras: a FATAL configuration error must end the node with a non-zero status.
check fatal_config_exits_nonzero "timeout 30 rosrun insitu_calibration calibration_node __name:=unconfigured; \
  status=\$?; echo \"exit status \$status\"; test \$status -eq 1"
# sim_time_guard clears /use_sim_time when it stops.
check sim_time_guard "rosparam set /use_sim_time true && (rosrun insitu_calibration sim_time_guard & pid=\$!; \
  sleep 3; kill -TERM \$pid; wait \$pid) ; ! rosparam get /use_sim_time"
[ "$failures" -eq 0 ]
