// Extra bytes of LAS point records: the descriptors of the Extra Bytes VLR (LAS 1.4 R15,
// section 2.5.2: 192 bytes each) turned into attribute columns, and back.
#include <algorithm>
#include <cctype>
#include <unordered_set>
#include <string>

#include "io_error.hpp"
#include "las_format.hpp"

namespace pointfair::io::detail {

namespace {

constexpr LasStorage kStorageOfType[] = {LasStorage::U8,  LasStorage::I8,  LasStorage::U16, LasStorage::I16,
                                         LasStorage::U32, LasStorage::I32, LasStorage::U64, LasStorage::I64,
                                         LasStorage::F32, LasStorage::F64};

// One descriptor: `elements` values of `storage`, or `undocumented` raw bytes (data type 0).
struct Descriptor {
  std::string name;
  LasStorage storage = LasStorage::U8;
  std::size_t elements = 1;
  std::size_t size = 0;  // bytes per record
};

std::vector<Descriptor> parse(const std::filesystem::path& file, std::string_view payload) {
  if (payload.size() % kExtraBytesDescriptorSize != 0) {
    fail(file, "Extra Bytes record of " + std::to_string(payload.size()) +
                   " bytes is not a whole number of 192-byte descriptors");
  }
  std::vector<Descriptor> out;
  for (std::size_t at = 0; at < payload.size(); at += kExtraBytesDescriptorSize) {
    const auto type = static_cast<unsigned char>(payload[at + 2]);
    const auto options = static_cast<unsigned char>(payload[at + 3]);
    Descriptor d;
    d.name = fixed_text(payload.substr(at + 4, 32));
    if (type == 0) {
      // Undocumented bytes: the options field holds their number.
      d.elements = options;
      d.size = options;
    } else if (type <= 30) {
      d.storage = kStorageOfType[(type - 1) % 10];
      d.elements = (type - 1) / 10 + 1;  // 11-30: deprecated arrays of 2 or 3
      d.size = d.elements * storage_size(d.storage);
    } else {
      fail(file, "Extra Bytes descriptor " + std::to_string(out.size()) + " has unknown data type " +
                     std::to_string(type));
    }
    out.push_back(std::move(d));
  }
  return out;
}

// Letters, digits and '_' only, so the name is usable in PLY headers and as an HDF5 name.
std::string clean_name(const std::string& raw) {
  std::string name;
  for (const char c : raw) {
    name += std::isalnum(static_cast<unsigned char>(c)) != 0 ? c : '_';
  }
  return name.empty() ? std::string("extra") : name;
}

}  // namespace

std::size_t described_extra_size(const std::filesystem::path& file, std::string_view descriptors) {
  std::size_t size = 0;
  for (const Descriptor& d : parse(file, descriptors)) size += d.size;
  return size;
}

std::vector<ExtraColumn> extra_columns(const std::filesystem::path& file, int format,
                                       std::string_view descriptors, std::size_t extra_size) {
  std::unordered_set<std::string> taken;  // the described names
  std::vector<ExtraColumn> columns;
  columns.reserve(extra_size);
  auto unique = [&](std::string name) {
    if (is_las_field_name(format, name) || taken.count(name) != 0) {
      std::string base = name;
      for (int k = 2; is_las_field_name(format, name) || taken.count(name) != 0; ++k) name = base + "_" + std::to_string(k);
    }
    return name;
  };
  auto add = [&](std::string name, LasStorage storage, std::size_t offset) {
    name = unique(std::move(name));
    taken.insert(name);
    columns.push_back({std::move(name), attribute_type_of(storage), storage, offset});
  };
  std::size_t offset = 0;
  const std::vector<Descriptor> list = parse(file, descriptors);
  for (const Descriptor& d : list) {
    if (d.size > extra_size - offset) {
      fail(file, "the Extra Bytes record describes more bytes than the " + std::to_string(extra_size) +
                     " extra bytes of each point record");
    }
    const std::string name = clean_name(d.name);
    const std::size_t element_size = d.size / std::max<std::size_t>(d.elements, 1);
    for (std::size_t e = 0; e < d.elements; ++e) {
      add(d.elements == 1 ? name : name + "_" + std::to_string(e), d.storage, offset + e * element_size);
    }
    offset += d.size;
  }
  // Undescribed bytes: "extra_byte_<k>" differ from each other and from every standard name,
  // so only the described names are checked (a record may hold 65,000 such bytes).
  for (std::size_t k = 0; offset < extra_size; ++k, ++offset) {
    std::string name = "extra_byte_" + std::to_string(k);
    if (!taken.empty()) name = unique(std::move(name));
    columns.push_back({std::move(name), ScalarType::UInt8, LasStorage::U8, offset});
  }
  return columns;
}

std::string extra_descriptor(const std::string& name, ScalarType type) {
  std::string d(kExtraBytesDescriptorSize, '\0');
  const LasStorage storage = storage_of(type);
  for (std::size_t t = 0; t < 10; ++t) {
    if (kStorageOfType[t] == storage) d[2] = static_cast<char>(t + 1);
  }
  d.replace(4, 32, padded(name, 32));
  return d;
}

}  // namespace pointfair::io::detail
