#!/usr/bin/env bash
# Task 5 with the real reference package: build BKISemanticMapping (C++/ROS 1, Gan et al. 2020)
# with catkin, run its own launch files on the toy scans and on SemanticKITTI sequence 04 under a
# virtual X server, save RViz screenshots and a video of RViz while the map grows, record the
# published MarkerArray with rosbag, and compare that map with ours (hw4.bki.rosref).
#
#   bash scripts/reference_ros.sh            # everything, with RViz (about 8 min after the install)
#   bash scripts/reference_ros.sh --no-rviz  # build, run the nodes headless, record, compare (CI)
#   bash scripts/reference_ros.sh --book     # also copy the screenshots and video to notebooks/_static
#
# Options: --out DIR (default out/ros), --no-rviz, --no-compare (record only; test.sh compares
# in tests/test_bki_rosref_ros.py), --book.
# Needs Debian 12 (or an Ubuntu with ROS 1 Noetic's Debian packages); installs them when run as
# root, otherwise prints the apt-get command. The workspace .ros_ws/ is git-ignored.
set -eo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
ROOT=$PWD
OUT=out/ros
RVIZ=1
BOOK=0
COMPARE=1
while [ $# -gt 0 ]; do
    case "$1" in
        --out) OUT=$2; shift 2 ;;
        --no-rviz) RVIZ=0; shift ;;
        --book) BOOK=1; shift ;;
        --no-compare) COMPARE=0; shift ;;
        -h|--help) sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "reference_ros: unknown option $1 (see --help)" >&2; exit 2 ;;
    esac
done
case "$OUT" in /*) ;; *) OUT=$ROOT/$OUT ;; esac
WS=${HW4_ROS_WS:-$ROOT/.ros_ws}   # the catkin workspace (git-ignored)
PKG=$WS/src/semantic_bki
PY=$ROOT/.venv/bin/python
LOG=$OUT/logs
T0=$(date +%s)
say() { echo "reference_ros [$(( $(date +%s) - T0 ))s]: $*"; }
die() { echo "reference_ros: $*" >&2; exit 1; }

# ----------------------------------------------------------------------------- 1. packages
DEBS="catkin libroscpp-dev rosbash python3-roslaunch python3-rosbag python3-rostopic libpcl-ros-dev \
libtf-conversions-dev libvisualization-msgs-dev libnav-msgs-dev libgeometry-msgs-dev libopencv-dev \
python3-tf2-msgs rviz xvfb xauth ffmpeg"
need_install=0
for tool in catkin_make roslaunch roscore rostopic rviz Xvfb ffmpeg; do
    command -v "$tool" >/dev/null 2>&1 || need_install=1
done
[ -x /usr/lib/rosbag/record ] || need_install=1
[ -e /usr/include/pcl_ros/point_cloud.h ] || need_install=1
[ -e /usr/include/tf_conversions/tf_eigen.h ] || need_install=1
[ -d /usr/lib/python3/dist-packages/tf2_msgs ] || need_install=1
if [ "$need_install" = 1 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        say "1/7 installing the ROS 1 packages of Debian (about 350 MB, several minutes)"
        export DEBIAN_FRONTEND=noninteractive
        apt-get -o DPkg::Lock::Timeout=1200 update -q
        # shellcheck disable=SC2086
        apt-get -o DPkg::Lock::Timeout=1200 install -y -q --no-install-recommends $DEBS
    else
        echo "reference_ros: the ROS 1 packages are missing. Install them (Debian 12) with:" >&2
        echo "  sudo apt-get install -y --no-install-recommends $DEBS" >&2
        exit 1
    fi
else
    say "1/7 the ROS 1 packages are installed"
fi
[ -x "$PY" ] || die "no .venv: run 'bash scripts/setup.sh' first."

# ----------------------------------------------------------------------------- 2. source
TARBALL=BKISemanticMapping-66e3258.tar.gz
COMMIT=66e32583c12b2c61acd2b0ffb2878d0dc05a69fa
URL=https://github.com/ganlumomo/BKISemanticMapping/archive/$COMMIT.tar.gz
TREE_SHA=$("$PY" -c "from hw4.bki.rosref import REF_TREE_SHA256; print(REF_TREE_SHA256)")
mkdir -p "$WS/src" "$LOG"
if [ ! -f "$PKG/.hw4-verified" ]; then
    rm -rf "$WS/src/semantic_bki" "$WS/src/extract"
    mkdir -p "$WS/src/extract"
    if [ -f "$ROOT/../shared/upstream/$TARBALL" ]; then
        say "2/7 source: ../shared/upstream/$TARBALL"
        tar -xzf "$ROOT/../shared/upstream/$TARBALL" -C "$WS/src/extract"
    else
        say "2/7 source: downloading $URL"
        "$PY" -c "import sys, urllib.request; urllib.request.urlretrieve(sys.argv[1], sys.argv[2])" \
            "$URL" "$WS/src/extract.tar.gz" || die "could not download $URL"
        tar -xzf "$WS/src/extract.tar.gz" -C "$WS/src/extract"
        rm -f "$WS/src/extract.tar.gz"
    fi
    top=$(find "$WS/src/extract" -mindepth 1 -maxdepth 1 -type d | head -1)
    got=$(cd "$top" && find . -type f | LC_ALL=C sort | xargs sha256sum | sha256sum | cut -d' ' -f1)
    [ "$got" = "$TREE_SHA" ] || die "the source tree's sha256 is $got, not the pinned $TREE_SHA; refusing to build it."
    mv "$top" "$PKG"
    rm -rf "$WS/src/extract"
    # ------------------------------------------------------------------------- 3. fixes
    say "3/7 fixing the package: -o3 -> -O3 (CMakeLists.txt), 'return *this;' in LeafIterator::operator++ (bkioctomap.h)"
    sed -i 's/ -o3"/ -O3"/' "$PKG/CMakeLists.txt"
    grep -q -- '-O3"' "$PKG/CMakeLists.txt" || die "CMakeLists.txt fix did not apply"
    "$PY" - "$PKG/include/semantic_bki/mapping/bkioctomap.h" <<'EOF'
import sys
p = sys.argv[1]
s = open(p).read()
a = s.index("LeafIterator &operator++() {")
b = s.index("SemanticOcTreeNode &operator*() const", a)
body = s[a:b]
end = body.rstrip().rfind("\n")               # the line of the function's closing brace
body = body[:end] + "\n                return *this;  // added: missing in the package" + body[end:]
open(p, "w").write(s[:a] + body + s[b:])
EOF
    grep -q "return \*this;  // added" "$PKG/include/semantic_bki/mapping/bkioctomap.h" || die "bkioctomap.h fix did not apply"
    touch "$PKG/.hw4-verified"
else
    say "2/7 source already verified and fixed in .ros_ws/src/semantic_bki"
fi

# ----------------------------------------------------------------------------- 4. build
# catkin and pluginlib break with a venv's python3 first on PATH: /usr/bin goes first.
export PATH=/usr/bin:/bin:$PATH
unset PYTHONPATH VIRTUAL_ENV
if [ ! -x "$WS/devel/lib/semantic_bki/semantickitti_node" ] || [ ! -x "$WS/devel/lib/semantic_bki/toy_example_node" ] \
        || [ "$PKG/.hw4-verified" -nt "$WS/devel/lib/semantic_bki/semantickitti_node" ]; then
    say "4/7 catkin_make -DCMAKE_BUILD_TYPE=Release: the toy and SemanticKITTI nodes (1.5-5 min)"
    # kitti_node (KITTI's stereo data, not the homework's) is left out: each node compiles the
    # mapping sources again, so this saves a third of the build
    (cd "$WS" && catkin_make -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=OFF \
        --pkg semantic_bki -j2 --make-args toy_example_node semantickitti_node > "$LOG/build.log" 2>&1) || { tail -30 "$LOG/build.log" >&2; die "the build failed (log: $LOG/build.log)"; }
else
    say "4/7 nodes already built"
fi
# shellcheck disable=SC1091
source "$WS/devel/setup.bash"
# A master of our own on a free port (HW4_ROS_PORT to choose one): a ROS master the user already
# runs on 11311, or a second run of this script, would otherwise see our nodes (a node registered
# twice under one name is shut down by the master).
ROS_PORT=${HW4_ROS_PORT:-$("$PY" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}
export ROS_MASTER_URI=http://localhost:$ROS_PORT ROS_HOME=$WS/.ros ROS_LOG_DIR=$LOG/ros
rospack find semantic_bki >/dev/null || die "ROS cannot find the package semantic_bki after the build"

# ----------------------------------------------------------------------------- 5. inputs
say "5/7 inputs: toy PCDs without their undeclared 5th value; sequence 04 with predictions/"
"$PY" -m hw4 data >/dev/null
TOY=$PKG/data/sim_unstructured_annotated
for f in "$TOY"/*.pcd; do
    # data lines carry x y z label and an undeclared fifth value, which PCL 1.13 rejects
    awk 'BEGIN{d=0} d{print $1, $2, $3, $4; next} {print} /^DATA/{d=1}' "$f" > "$f.tmp" && mv "$f.tmp" "$f"
done
SEQ=$ROOT/data/semantickitti_04/sequences/04
KD=$PKG/data/semantickitti_04
mkdir -p "$KD/evaluations"
ln -sfn "$SEQ/velodyne" "$KD/velodyne"
ln -sfn "$SEQ/labels" "$KD/labels"
ln -sfn "$SEQ/poses.txt" "$KD/poses.txt"
NSCANS=$(find "$SEQ/velodyne" -name '*.bin' | wc -l)
for src in clean noisy; do
    [ -d "$KD/predictions_$src" ] && [ "$(find "$KD/predictions_$src" -name '*.label' | wc -l)" = "$NSCANS" ] || \
        "$PY" -m hw4.bki.rosref predictions "$SEQ" "$KD/predictions_$src" --labels "$src"
done
# the node reads scan_num scans and crashes past the last one: no more than are on disk
sed -i "s/^scan_num: .*/scan_num: $(( NSCANS < 100 ? NSCANS : 100 )) # scans on disk (was 100)/" \
    "$PKG/config/datasets/semantickitti.yaml"
# the package's launch files without their RViz node, for the headless runs
for l in semantickitti_node toy_example_node; do
    grep -v 'type="rviz"' "$PKG/launch/$l.launch" > "$PKG/launch/${l}_norviz.launch"
done

# ----------------------------------------------------------------------------- 6. runs
PIDS=()
cleanup() {
    for pid in "${PIDS[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
    sleep 1
    for pid in "${PIDS[@]}"; do kill "$pid" 2>/dev/null || true; done
}
trap cleanup EXIT
start_master() {
    roscore -p "$ROS_PORT" > "$LOG/roscore.log" 2>&1 &
    MASTER=$!
    PIDS+=("$MASTER")
    for _ in $(seq 60); do rostopic list >/dev/null 2>&1 && return 0; sleep 0.5; done
    die "roscore did not come up (log: $LOG/roscore.log)"
}
stop() {  # SIGINT to a PID and wait for it (roslaunch and rosbag record finish cleanly on SIGINT;
    # roslaunch gives its nodes 15 s before it escalates)
    kill -INT "$1" 2>/dev/null || true
    for _ in $(seq 100); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.25; done
    kill "$1" 2>/dev/null || true
}
wait_for() {  # wait_for FILE PATTERN COUNT TIMEOUT: until PATTERN occurs COUNT times in FILE;
    # returns 3 when a node died (see crashed), stops the script on a timeout
    local n=0
    for _ in $(seq $(( $4 * 2 ))); do
        n=$(grep -c -- "$2" "$1" 2>/dev/null || true)
        [ "${n:-0}" -ge "$3" ] && return 0
        if grep -q "process has died" "$1" 2>/dev/null; then
            return 3
        fi
        sleep 0.5
    done
    tail -20 "$1" >&2
    die "timed out waiting for '$2' x$3 in $1"
}
crashed() {  # crashed LOG ATTEMPT: keep the log of a crashed run and say so
    cp "$1" "${1%.log}.crash$2.log"
    say "   the node crashed (segmentation fault: the package's OpenMP data race on block_arr strikes"
    say "   now and then); attempt $2 of 3, log kept as ${1%.log}.crash$2.log"
}
start_launch() {  # start_launch NAME LAUNCH PATTERN COUNT: roslaunch until PATTERN occurs COUNT
    # times in its log; a run whose node crashes is started again (three attempts)
    local attempt rc
    for attempt in 1 2 3; do
        roslaunch semantic_bki "$2" > "$LOG/$1.log" 2>&1 &
        LAUNCH=$!
        PIDS+=("$LAUNCH")
        rc=0
        wait_for "$LOG/$1.log" "$3" "$4" 900 || rc=$?
        [ "$rc" = 0 ] && return 0
        crashed "$LOG/$1.log" "$attempt"
        stop "$LAUNCH"
    done
    die "the node crashed three times (logs: $LOG/$1.crash*.log)"
}
XVFB_DISPLAYS=()
start_x() {  # start_x N: a virtual screen :N, 2048x1400, 24 bit
    Xvfb ":$1" -screen 0 2048x1400x24 -nolisten tcp > "$LOG/xvfb$1.log" 2>&1 &
    PIDS+=("$!")
    for _ in $(seq 40); do [ -e "/tmp/.X11-unix/X$1" ] && return 0; sleep 0.25; done
    die "Xvfb :$1 did not start"
}
grab() {  # grab DISPLAY X Y W H FILE: one screenshot of a screen region
    ffmpeg -loglevel error -y -f x11grab -draw_mouse 0 -video_size "${4}x${5}" -i ":$1+$2,$3" -frames:v 1 "$6"
}
grab_stable() {  # like grab, once two grabs 3 s apart agree above the bottom 120 px (RViz's
    # time panel there changes every second): RViz has finished drawing the map
    local prev="" cur
    for _ in $(seq 60); do
        grab "$@"
        cur=$(ffmpeg -loglevel error -i "$6" -vf "crop=iw:ih-120:0:0" -f md5 - 2>/dev/null)
        [ "$cur" = "$prev" ] && return 0
        prev=$cur
        sleep 3
    done
    say "   (the view kept changing for 3 min; kept the last screenshot)"
}

bag_run() {  # bag_run NAME LAUNCH DONE_PATTERN DONE_COUNT TOPICS...: run a launch file, record TOPICS
    # (a run whose node crashes is started again with a new recording, three attempts)
    local name=$1 launch=$2 pat=$3 cnt=$4 attempt rc rec
    shift 4
    for attempt in 1 2 3; do
        rm -f "$OUT/$name.bag" "$OUT/$name.bag.active"
        /usr/lib/rosbag/record -O "$OUT/$name.bag" "$@" > "$LOG/$name.record.log" 2>&1 &
        rec=$!
        PIDS+=("$rec")
        sleep 2
        roslaunch semantic_bki "$launch" > "$LOG/$name.log" 2>&1 &
        LAUNCH=$!
        PIDS+=("$LAUNCH")
        rc=0
        wait_for "$LOG/$name.log" "$pat" "$cnt" 900 || rc=$?
        if [ "$rc" = 0 ]; then
            sleep 3                                       # the last map reaches the recorder
            stop "$rec"
            [ -f "$OUT/$name.bag" ] || die "rosbag record wrote no $name.bag (log: $LOG/$name.record.log)"
            return 0
        fi
        crashed "$LOG/$name.log" "$attempt"
        stop "$LAUNCH"
        stop "$rec"
    done
    die "the node crashed three times (logs: $LOG/$name.crash*.log)"
}

say "6/7 running the nodes (ROS_MASTER_URI=$ROS_MASTER_URI)"
start_master
# The package publishes its markers in the frame "map", its RViz configurations' fixed frame, but
# no transform at all, so RViz reports "Fixed Frame: No TF data" and an error on every MarkerArray
# display ("frame [map] does not exist"), although it draws the markers. A latched identity
# transform from "map" (to a frame of no use) makes "map" known to TF: the panels show no error.
rostopic pub -l /tf_static tf2_msgs/TFMessage \
    '{transforms: [{header: {frame_id: map}, child_frame_id: map_origin, transform: {rotation: {w: 1.0}}}]}' \
    > "$LOG/tf_static.log" 2>&1 &
PIDS+=("$!")
for src in clean noisy; do
    ln -sfn "predictions_$src" "$KD/predictions"
    say "   semantickitti_node, $NSCANS scans, $src labels, without RViz"
    bag_run "kitti04_${src}" semantickitti_node_norviz.launch "Inserted point cloud" "$NSCANS" /occupied_cells_vis_array
    stop "$LAUNCH"
done
ln -sfn predictions_clean "$KD/predictions"
say "   toy_example_node (S-CSM, then S-BKI, 12 scans), without RViz"
bag_run toy toy_example_node_norviz.launch "min_var" 2 /semantic_csm /semantic_bki
grep -h "finished in" "$LOG/toy.log" | sed -e "s/\x1b\[[0-9;]*m//g" -e "s/^/   node: /" || true
stop "$LAUNCH"

if [ "$RVIZ" = 1 ]; then
    DISP=91
    while [ -e "/tmp/.X$DISP-lock" ]; do DISP=$((DISP + 1)); done
    start_x "$DISP"
    export DISPLAY=:$DISP QT_X11_NO_MITSHM=1 LIBGL_ALWAYS_SOFTWARE=1
    # The package's RViz windows are 1855 x 1056 at (167, 307) (SemanticKITTI) and (65, 312) (toy)
    say "   roslaunch semantic_bki semantickitti_node.launch with RViz, recording the screen"
    ffmpeg -loglevel error -y -f x11grab -draw_mouse 0 -framerate 10 -video_size 1854x1056 \
        -i ":$DISP+167,307" -c:v libx264 -preset veryfast -pix_fmt yuv420p -crf 26 \
        -vf "scale=1280:-2" "$OUT/rviz_kitti04_mapping_raw.mp4" > "$LOG/ffmpeg.log" 2>&1 &
    FF=$!
    FF_T0=$(date +%s.%N)
    PIDS+=("$FF")
    bag_run kitti04_rviz semantickitti_node.launch "Inserted point cloud" "$NSCANS" /occupied_cells_vis_array
    grab_stable "$DISP" 167 307 1854 1056 "$OUT/rviz_kitti04.png"
    sleep 2
    kill -INT "$FF"; wait "$FF" 2>/dev/null || true
    stop "$LAUNCH"
    # more views of the same (latched) map: a top view and a closer view, RViz alone, full window
    ln -sfn predictions_clean "$KD/predictions"
    start_launch kitti04_views semantickitti_node_norviz.launch "Inserted point cloud" "$NSCANS"
    rv() {  # rv SRC NAME TOPICS [VIEW]: RViz with a config copy (window at (0, 0), --fullscreen: no
        # panels), screenshot, close
        "$PY" -m hw4.bki.rosref rviz-config "$PKG/rviz/$1" "$WS/$2.rviz" --topics "$3" ${4:+--view "$4"}
        rviz --fullscreen -d "$WS/$2.rviz" > "$LOG/$2.log" 2>&1 &
        local r=$!
        PIDS+=("$r")
        sleep 5
        grab_stable "$DISP" 0 0 1854 1056 "$OUT/$2.png"   # the window: the config's size at (0, 0)
        stop "$r"
    }
    say "   RViz views of sequence 04 (top, close)"
    rv semantickitti_node.rviz rviz_kitti04_top /occupied_cells_vis_array \
        '{"Class": "rviz/TopDownOrtho", "Scale": 9.5, "X": 0, "Y": 6, "Angle": 1.5708}'
    rv semantickitti_node.rviz rviz_kitti04_close /occupied_cells_vis_array \
        '{"Class": "rviz/Orbit", "Distance": 45, "Focal Point": [0, 14, 0], "Pitch": 0.5, "Yaw": -1.5708}'
    stop "$LAUNCH"
    say "   roslaunch semantic_bki toy_example_node.launch with RViz"
    start_launch toy_rviz toy_example_node.launch "min_var" 2
    grab_stable "$DISP" 65 312 1854 1056 "$OUT/rviz_toy.png"
    stop "$LAUNCH"
    # its four maps one at a time (the launch file shows all four on top of each other), in the
    # package's camera; the node alone, so that no other RViz window is on the screen
    start_launch toy_views toy_example_node_norviz.launch "min_var" 2
    for t in semantic_csm semantic_bki semantic_csm_variance semantic_bki_variance; do
        rv toy_example_node.rviz "rviz_toy_$t" "/$t" ""
    done
    stop "$LAUNCH"
    # a strip of frames of the video for print: the 3D view after scans 2, 3, 4, 6, 8 and 10
    # (the video is 1280 px wide; RViz's 3D view is the region 812 x 624 at (265, 43))
    "$PY" -c "import sys; from hw4.bki.rosref import video_strip as v; \
v(sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4], crop='812:624:265:43')" \
        "$OUT/rviz_kitti04_mapping_raw.mp4" "$OUT/kitti04_rviz.bag" "$FF_T0" "$OUT/rviz_kitti04_mapping_strip.png"
    # the video from the first frame with the map drawn in the 3D view (the recording starts with
    # a black screen, RViz's splash and its empty window), and its poster frame (the whole map)
    "$PY" -c "import sys; from hw4.bki import render as r; \
t = r.first_coloured_frame(sys.argv[1], crop='812:624:265:43', ffmpeg='ffmpeg'); \
r.trim_video(sys.argv[1], sys.argv[2], t, ffmpeg='ffmpeg'); \
r.video_poster(sys.argv[2], sys.argv[3], ffmpeg='ffmpeg'); print(f'   video from {t:.1f} s on')" \
        "$OUT/rviz_kitti04_mapping_raw.mp4" "$OUT/rviz_kitti04_mapping.mp4" "$OUT/rviz_kitti04_mapping_poster.jpg"
fi

# ----------------------------------------------------------------------------- 7. compare
if [ "$COMPARE" = 1 ]; then
say "7/7 comparing the recorded maps with ours (hw4.bki.rosref)"
for src in clean noisy; do
    "$PY" -m hw4.bki.rosref compare semantickitti "$OUT/kitti04_${src}.bag" --labels "$src" \
        --scans "$NSCANS" --json "$OUT/compare_kitti04_${src}.json" > /dev/null
done
"$PY" -m hw4.bki.rosref compare toy "$OUT/toy.bag" --json "$OUT/compare_toy.json" > /dev/null
"$PY" - "$OUT" <<'EOF'
import json, sys
out = sys.argv[1]
for name in ("kitti04_clean", "kitti04_noisy", "toy"):
    r = json.load(open(f"{out}/compare_{name}.json"))
    for k, v in r.items():
        if isinstance(v, dict):
            print(f"   {name:14s} {k:12s} Jaccard {v['jaccard']:.4f}  class agreement {v['class_agree']:.4f}"
                  f"  reference {v['ref']:7d}  ours {v['ours']:7d}  only reference {v['only_ref']:5d}  only ours {v['only_ours']:5d}")
    if "node_s_per_scan" in r:
        print(f"   {name:14s} node: {r['node_s_per_scan']:.2f} s per scan (between published maps)")
EOF
fi
if [ "$BOOK" = 1 ] && [ "$RVIZ" = 1 ]; then
    say "copying the screenshots and the video to notebooks/_static (t5_rviz_*)"
    for f in "$OUT"/rviz_kitti04*.png "$OUT"/rviz_toy_*.png "$OUT"/rviz_kitti04_mapping.mp4 \
            "$OUT"/rviz_kitti04_mapping_poster.jpg; do
        cp "$f" "$ROOT/notebooks/_static/t5_$(basename "$f")"
    done
    # the published maps, compactly, for the chapter's comparison (the bags are 40 MB each)
    "$PY" -c "import sys; from hw4.bki.rosref import save_reference_maps as s; \
print(s(sys.argv[1], {'kitti04_clean': sys.argv[2], 'kitti04_noisy': sys.argv[3], 'toy': sys.argv[4], \
'kitti04_rviz': sys.argv[5]}))" "$ROOT/notebooks/reference_ros" "$OUT/kitti04_clean.bag" \
        "$OUT/kitti04_noisy.bag" "$OUT/toy.bag" "$OUT/kitti04_rviz.bag"
    cp "$LOG/toy.log" "$ROOT/notebooks/reference_ros/toy_node.log"
fi
say "done: $OUT (bags, screenshots, video, compare_*.json, logs/)"
