# Sourced by the README's commands: the newest nanoflann, the anchor our structures are measured against,
# is built in as nanoflann_latest when NNB_NANOFLANN_LATEST_DIR names a checkout, or when the shared
# folder beside the clone holds one. Without either, that adapter is simply off.
anchor_dir="../shared/anchors/nanoflann-1.12.1"
if [ -z "${NNB_NANOFLANN_LATEST_DIR:-}" ] && [ -f "${anchor_dir}/include/nanoflann.hpp" ]; then
  NNB_NANOFLANN_LATEST_DIR="$(cd "${anchor_dir}" && pwd)"
  export NNB_NANOFLANN_LATEST_DIR
fi
