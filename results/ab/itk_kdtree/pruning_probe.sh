#!/usr/bin/env bash
# ITK's KdTree with its own BoundsOverlapBall against the same tree pruning by the summed box distance: the
# probe built twice, the second time against a copy of ITK's k-d tree headers in a temporary folder whose
# BoundsOverlapBall adds every axis's squared offset before comparing with the squared radius (ITK's returns at
# the first axis the query lies outside of). Nothing of ITK is kept. Usage: pruning_probe.sh SCAN.3d [ROUNDS]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
scan=$1 rounds=${2:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
itk=/usr/include/ITK-5.2
mkdir "$work/patched"
cp "$itk"/itkKdTree.h "$itk"/itkKdTree.hxx "$itk"/itkKdTreeGenerator.h "$itk"/itkKdTreeGenerator.hxx "$work/patched/"
python3 - "$work/patched/itkKdTree.hxx" <<'PY'
import sys
from pathlib import Path
p = Path(sys.argv[1])
t = p.read_text()
start = t.index("{", t.index("KdTree<TSample>::BoundsOverlapBall("))
end = t.index("\n}\n", start) + 2
t = t[:start] + """{
  double sum = 0.0;
  for (unsigned int d = 0; d < this->m_MeasurementVectorSize; ++d)
  {
    if (query[d] <= lowerBound[d]) sum += itk::Math::sqr(query[d] - lowerBound[d]);
    else if (query[d] >= upperBound[d]) sum += itk::Math::sqr(query[d] - upperBound[d]);
  }
  return sum < itk::Math::sqr(radius);
}
""" + t[end:]
p.write_text(t)
PY
libs="-lITKStatistics-5.2 -lITKCommon-5.2 -litksys-5.2 -litkvnl-5.2 -litkvnl_algo-5.2 -litkNetlibSlatec-5.2"
g++ -O2 -DNDEBUG -std=c++17 -isystem "$itk" "$here/pruning_probe.cpp" -o "$work/stock" $libs
g++ -O2 -DNDEBUG -std=c++17 -isystem "$work/patched" -isystem "$itk" "$here/pruning_probe.cpp" -o "$work/summed" $libs
for ((r = 1; r <= rounds; r++)); do
  echo "round $r stock:  $("$work/stock" "$scan")"
  echo "round $r summed: $("$work/summed" "$scan")"
done
