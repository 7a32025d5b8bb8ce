#pragma once
// What the four VTK locator adapters share: points handed to VTK without a copy, the version VTK reports
// at run time, single-threaded builds, and id lists read into result rows.
#include "nnb/search_index.hpp"

#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSMPTools.h>
#include <vtkSmartPointer.h>
#include <vtkVersion.h>

#include <string>
#include <utility>

namespace nnb::adapters::vtk {

/// The VTK version the program runs against, e.g. "9.1.0".
inline std::string vtk_version() { return vtkVersion::GetVTKVersion(); }

/// A point set over array (3 components a tuple), which the locators take as their data set.
inline vtkSmartPointer<vtkPolyData> point_set(vtkDataArray* array) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetData(array);
  auto data = vtkSmartPointer<vtkPolyData>::New();
  data->SetPoints(points);
  return data;
}

/// Runs build (a BuildLocator call) on this thread only: vtkStaticPointLocator bins and vtkDataArray computes
/// bounds through vtkSMPTools, whose TBB backend would otherwise use every core, unlike the other adapters.
template <class Build>
void build_single_threaded(Build&& build) {
  vtkSMPTools::LocalScope(vtkSMPTools::Config{1, "Sequential", false}, std::forward<Build>(build));
}

/// A VTK object of class T (a subclass of ours) created the way vtkStandardNewMacro creates VTK's own.
template <class T>
T* new_vtk_object() {
  T* object = new T;
  object->InitializeObjectBase();
  return object;
}

}  // namespace nnb::adapters::vtk
