# All third-party packages, found once. Every one comes from Debian 12 (tools/debian-packages.txt).
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(SQLite3 REQUIRED)
find_package(CURL REQUIRED)
find_package(OpenImageIO CONFIG REQUIRED)
# libjpeg-turbo and libpng (what OpenImageIO uses for JPEG and PNG), PRIVATE to the codec module
# (codec/), which the proxy and the renderer link: they are small, so composing maps and rendering
# tiles never loads OpenImageIO, and a map decodes only the part of each JPEG tile it samples.
find_package(JPEG REQUIRED)
find_package(PNG REQUIRED)
# zlib: the values module inflates Deflate TIFFs itself (libpng needs it anyway).
find_package(ZLIB REQUIRED)
# Debian 12's OpenImageIO config lists /usr/include/opencv4 although OpenImageIO's headers never
# need it; drop include directories that do not exist rather than pull in all of OpenCV.
foreach(_oiio_target OpenImageIO::OpenImageIO OpenImageIO::OpenImageIO_Util)
  if(TARGET ${_oiio_target})
    get_target_property(_dirs ${_oiio_target} INTERFACE_INCLUDE_DIRECTORIES)
    set(_kept "")
    foreach(_d IN LISTS _dirs)
      if(EXISTS "${_d}")
        list(APPEND _kept "${_d}")
      endif()
    endforeach()
    set_target_properties(${_oiio_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_kept}")
  endif()
endforeach()
list(APPEND CMAKE_MODULE_PATH /usr/share/cmake/geographiclib)
find_package(GeographicLib REQUIRED)
if(NOT TARGET GeographicLib::GeographicLib)
  add_library(GeographicLib::GeographicLib INTERFACE IMPORTED)
  target_include_directories(GeographicLib::GeographicLib INTERFACE ${GeographicLib_INCLUDE_DIRS})
  target_link_libraries(GeographicLib::GeographicLib INTERFACE ${GeographicLib_LIBRARIES})
endif()
find_package(glm CONFIG REQUIRED)
find_package(glfw3 CONFIG REQUIRED)
find_package(fmt CONFIG REQUIRED)
find_package(yaml-cpp CONFIG REQUIRED)
# JSON (flight paths, render statistics): header-only, PRIVATE to the module that reads or writes it.
find_package(nlohmann_json 3.11 CONFIG REQUIRED)
# Boost.Beast + Asio (header-only) for the HTTP server; see docs/design/dependencies.md.
find_package(Boost 1.74 REQUIRED)
# Open MPI (issue 28: `tellus cluster`; PRIVATE to tellus::cluster)
# The C API from C++ (the project enables no C; the deprecated C++ bindings left out).
set(MPI_CXX_SKIP_MPICXX ON)
find_package(MPI REQUIRED COMPONENTS CXX)
# VESA MPCDI (issue 28): libzip reads the .mpcdi archive and expat its mpcdi.xml, PRIVATE to
# tellus::mpcdi (mpcdi/). libzip through pkg-config: Debian 12's CMake config of libzip-dev names
# the zipcmp tools of another package and fails without them.
pkg_check_modules(LIBZIP REQUIRED IMPORTED_TARGET libzip)
find_package(EXPAT REQUIRED)
pkg_check_modules(EPOXY REQUIRED IMPORTED_TARGET epoxy)
if(TELLUS_BUILD_TESTS)
  find_package(GTest CONFIG REQUIRED)
  include(GoogleTest)
endif()
if(TELLUS_BUILD_BENCH)
  find_package(benchmark CONFIG REQUIRED)
endif()
# libpq (issue 27): the PostgreSQL index and leases of tellus::cache_pg, PRIVATE to that module.
pkg_check_modules(LIBPQ REQUIRED IMPORTED_TARGET libpq)
