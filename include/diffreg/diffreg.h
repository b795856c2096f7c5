/// \file
/// \brief Everything a program embedding diffreg needs, in one include.
///
/// \mainpage diffreg API
///
/// diffreg deforms planar triangle meshes, surfaces and tetrahedral solids with variational
/// energies (ARAP, ASAP, linearized ARAP, Dirichlet) regularized by diffused, non-uniform
/// weights (Zhu, Li, Zhang, Song, Computer-Aided Design 2016). Link the installed package with
///
///     find_package(diffreg 0.1 CONFIG REQUIRED)
///     target_link_libraries(my_program PRIVATE diffreg::diffreg)
///
/// and include `<diffreg/diffreg.h>`. Four levels of use:
///
/// - **One-shot functions on your own OpenMesh mesh** (diffreg/openmesh.h):
///   diffreg::computeDiffusedWeights, diffreg::deform, diffreg::measure and
///   diffreg::runPipeline store their results as the properties `diffreg:weight` (vertex) and
///   `diffreg:distortion`, `diffreg:smoothness` (face) on any
///   `OpenMesh::TriMesh_ArrayKernelT<Traits>` and leave its other properties alone.
/// - **Editing sessions** that keep their factorizations between edits and count the work
///   (SolverStats): diffreg::DiffusionWeights (a new t or range costs one numeric
///   factorization, a new magnitude one solve; the second order's solve is a few conjugate
///   gradient iterations against one factor) and diffreg::DeformationSession (new targets
///   cost one solve per iteration), both on a diffreg::Discretization of a diffreg::Mesh
///   (diffreg::fromOpenMesh, diffreg::readMesh or the shapes of mesh/shapes.h).
/// - **The edit engine** diffreg::EditEngine: one rest mesh with its handles and parameters,
///   keeping the weights, the deformation, its unregularized reference, the per-element maps
///   and the metrics up to date at the least cost (the filters, the one-shot functions and the
///   `diffreg serve` editor all run on it).
/// - **Pipelines of filters**: diffreg::Pipeline with filter names and parameter maps from
///   diffreg::Registry::builtin(), run on a diffreg::Document; the same filters and parameter
///   tables as the `diffreg` command-line tool and its `.mlx` scripts.
///
/// Nothing else is declared: the residual operators, systems, solvers and acceleration behind
/// these levels stay in the library (tests/test_api_surface.cpp checks it).
///
/// Every error is a diffreg::Error subclass (core/error.h) with a one-line message naming the
/// file, element or parameter at fault. Warnings go to stderr ("diffreg: warning: ..."):
/// setQuiet(true) silences them, and a WarningCollector (core/log.h) takes a thread's warnings
/// for the host to pass on. `<diffreg/version.h>` defines DIFFREG_VERSION_MAJOR,
/// DIFFREG_VERSION_MINOR, DIFFREG_VERSION_PATCH and DIFFREG_VERSION_STRING.
#pragma once

#include <diffreg/version.h>

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/metrics.h>
#include <diffreg/deformation/options.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/engine/edit_engine.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/mesh.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/pipeline/document.h>
#include <diffreg/pipeline/filter.h>
#include <diffreg/pipeline/params.h>
#include <diffreg/pipeline/pipeline.h>
#include <diffreg/solver/backend.h>
#include <diffreg/weights/diffusion.h>
#include <diffreg/weights/rbf.h>
#include "plugins.h"

#include <diffreg/openmesh.h>
