# Sourced by the scripts that build: parallel_jobs MIB_EACH prints how many jobs to run at once. One a core
# (nproc), but no more than the available memory holds at MIB_EACH each, and at least one: a machine with many
# cores and little memory would otherwise swap or lose a compiler to the OOM killer (this project's heaviest
# translation units take up to 0.7 GiB under gcc, 0.9 GiB with the sanitizers). NNB_JOBS=N sets it.
parallel_jobs() {
  local each_mib=$1 cores available_kib fit
  if [ -n "${NNB_JOBS:-}" ]; then
    if ! [[ "${NNB_JOBS}" =~ ^[1-9][0-9]*$ ]]; then
      echo "parallel_jobs: NNB_JOBS must be a whole number of at least 1, not '${NNB_JOBS}'" >&2
      return 2
    fi
    echo "${NNB_JOBS}"
    return 0
  fi
  cores=$(nproc 2>/dev/null || echo 2)
  available_kib=$(awk '/^MemAvailable:/ {print $2; exit}' "${NNB_MEMINFO:-/proc/meminfo}" 2>/dev/null || true)
  if ! [[ "${available_kib}" =~ ^[0-9]+$ ]]; then
    echo "${cores}"
    return 0
  fi
  fit=$((available_kib / (each_mib * 1024)))
  ((fit >= 1)) || fit=1
  echo $((fit < cores ? fit : cores))
}

# Compilers and linkers at once; 1.5 GiB each leaves room for the sanitizer builds and the links.
build_jobs() {
  parallel_jobs 1536
}
