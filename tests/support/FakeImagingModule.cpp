// An imaging module of another version of the function table, for the loader's version check.

#include <tellus/imaging/ImagingApi.hpp>

extern "C" __attribute__((visibility("default"))) const TellusImagingTable* tellus_imaging_table() {
  static const TellusImagingTable table{999u,
                                        sizeof(TellusImagingTable),
                                        nullptr,
                                        nullptr,
                                        nullptr,
                                        nullptr,
                                        nullptr,
                                        nullptr,
                                        nullptr,
                                        nullptr};
  return &table;
}
