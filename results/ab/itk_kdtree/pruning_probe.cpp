// A/B probe, not part of the benchmark (pruning_probe.sh builds it twice): ITK's KdTree, bucket 16, searching
// the 2 nearest (as the adapter asks for 1-NN) of every point of a scan moved by normal noise of s.d. 0.02 a
// coordinate, in the scan's units (3DTK's SICK scans are in centimetres: 0.2 mm).
// Prints the time a query and the sum of nearest distances, which must be the same for both builds.
#include <itkKdTreeGenerator.h>
#include <itkVectorContainer.h>
#include <itkVectorContainerToListSampleAdaptor.h>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
using P = itk::Point<double, 3>;
using C = itk::VectorContainer<itk::IdentifierType, P>;
using S = itk::Statistics::VectorContainerToListSampleAdaptor<C>;
using G = itk::Statistics::KdTreeGenerator<S>;
int main(int, char** argv) {
  auto pts = C::New();
  std::ifstream in(argv[1]);
  double x, y, z;
  while (in >> x >> y >> z) { P p; p[0] = x; p[1] = y; p[2] = z; pts->push_back(p); }
  auto s = S::New(); s->SetVectorContainer(pts); s->SetMeasurementVectorSize(3);
  auto g = G::New(); g->SetSample(s); g->SetBucketSize(16); g->Update();
  auto tree = g->GetOutput();
  std::mt19937_64 rng(1); std::normal_distribution<double> n(0, 0.02);
  G::KdTreeType::InstanceIdentifierVectorType ids; std::vector<double> dists;
  double sum = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < pts->Size(); ++i) {
    P q = pts->ElementAt(i); q[0] += n(rng); q[1] += n(rng); q[2] += n(rng);
    tree->Search(q, 2, ids, dists);
    sum += std::min(dists[0], dists[1]);
  }
  const double s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%zu points, %.3f s, %.1f us a query, sum of nearest %.9g\n", pts->Size(), s_, 1e6 * s_ / pts->Size(), sum);
}
