// The run file and its commit record: created or resumed, shared by the ranks, committed.
#include "run.hpp"

#include <cstdio>

#include "key_difference.hpp"
#include "parameter_forms.hpp"
#include "pointfair/finish/quadric_parameters.hpp"
#include "pointfair/smooth_parameters.hpp"

namespace pointfair::tiles::detail {

// Every parameter that changes the result, as one line: stored in the run and compared on
// --resume. The table of smooth_parameters.hpp in its order; some entries only when they hold.
std::string parameters_key(const SmoothParams& p) {
  std::ostringstream s;
  s.precision(17);
  const char* separator = "";
  for (const SmoothParameter& parameter : kSmoothParameters) {
    if (parameter.key_when != nullptr && !parameter.key_when(p)) continue;
    s << separator;
    separator = " ";
    write_key(s, parameter.key, parameter.value(p), parameter.key_by_name);
  }
  return s.str();
}

// Every parameter of the quadric finish (its table, in the table's order; some entries only
// when they hold), for the same line.
std::string finish_key(const QuadricProjectionParams& q) {
  std::ostringstream s;
  s.precision(17);
  const char* separator = "";
  for (const QuadricParameter& parameter : kQuadricParameters) {
    if (parameter.key_when != nullptr && !parameter.key_when(q)) continue;
    s << separator;
    separator = " ";
    write_key(s, parameter.key, parameter.value(q));
  }
  return s.str();
}

std::string Run::key() const {
  std::string k = parameters_key(params_);
  // Named only when on, so that runs without it started before it existed still resume.
  if (params_.finish) {
    k += ' ';
    k += finish_key(*params_.finish);
    // The input points placed along the normals in the last pass (SmoothParams::placement).
    if (params_.placement == Placement::AlongNormal) {
      k += " placement=";
      k += stored_name_of(Placement::AlongNormal);
    }
  }
  if (!options_.neighbor_reference.empty()) {
    std::error_code ec;
    const auto size = fs::file_size(options_.neighbor_reference, ec);
    k += " neighbors_from=";
    k += options_.neighbor_reference.filename().string();
    k += ':';
    k += std::to_string(ec ? 0 : size);
  }
  if (!options_.start_positions.empty()) k += " start_from=" + options_.start_positions.filename().string();
  return k;
}

void Run::account(std::uint64_t working) {
  max_working_ = std::max(max_working_, working);
  const std::uint64_t total = persistent_bytes() + working;
  peak_ = std::max(peak_, total);
  if (total > options_.memory_budget) refuse(total);
}

void Run::refuse(std::uint64_t total) const {
  throw BudgetError("the memory budget of " + size_text(options_.memory_budget, false) +
                        " is too small for the tiles of " + input_path_.string() + " (the run needs " +
                        size_text(total, true) +
                        "): give a larger budget, or import the input again with a smaller budget (smaller tiles)",
                    options_.memory_budget, total);
}

void Run::commit_state(const std::vector<std::int64_t>& record) {
  // Everything written before this point (by every rank) reaches the file first; then rank 0
  // overwrites the small state record in place (its storage was allocated when the file was
  // created, so the write changes no metadata).
  file().flush();
  if (shared_) ranks_->barrier();
  if (ranks_->rank() == 0) file().dataset(layout::run_state).write_rows(0, state_rows_, record.data());
  file().flush();
}

void Run::share() {
  // Rank 0 created or checked the file alone; now every rank opens it for parallel I/O.
  if (ranks_->size() > 1) {
    file_.reset();
    ranks_->barrier();
    file_.emplace(ranks_->open_shared(partial_name(output_)));
    state_ = file().dataset(layout::run_state).read_all<std::int64_t>();
    state_rows_ = state_.size();
    state_.resize(kStateSize, 0);
  }
  shared_ = true;
}

void Run::release() {
  // The end of the parallel part: rank 0 alone finishes the file (metadata changes).
  if (ranks_->size() > 1) {
    file_.reset();
    ranks_->barrier();
    if (ranks_->rank() == 0) file_.emplace(h5::File::open(partial_name(output_), true));
  }
  shared_ = false;
}

// Collective writes: every rank writes as many tiles as the rank with the most non-empty
// tiles, the missing ones as empty selections (h5::Transfer::Collective).
std::uint64_t Run::my_tiles() const {
  std::uint64_t mine = 0;
  for (std::size_t t = first_tile_; t < end_tile_; ++t) mine += tiles_.rows(t) > 0;
  return mine;
}

std::uint64_t Run::tiles_to_write() const {
  std::array<std::uint64_t, 1> most = {my_tiles()};
  ranks_->max(most);
  return most[0];
}

void Run::balance(bool with_halo) {
  std::vector<std::uint64_t> costs(tiles_.size());
  for (std::size_t t = 0; t < tiles_.size(); ++t) costs[t] = tiles_.rows(t);
  // A run started before the halo counts were recorded balances by points alone.
  if (with_halo && !tiles_.bounds.empty() && file().exists(layout::neighbor_halo_counts)) {
    const auto halo = file().dataset(layout::neighbor_halo_counts).read_all<std::uint64_t>();
    halo_points_ = 0;
    for (std::size_t t = 0; t < costs.size() && t < halo.size(); ++t) {
      costs[t] += halo[t];
      halo_points_ += halo[t];
    }
  }
  const std::vector<std::size_t> b = balance_ranges(costs, ranks_->size());
  first_tile_ = b[static_cast<std::size_t>(ranks_->rank())];
  end_tile_ = b[static_cast<std::size_t>(ranks_->rank()) + 1];
}

void Run::create(const fs::path& partial, const std::string& digest) {
  const h5::File in = h5::File::open(input_path_, false);
  file_.emplace(h5::File::create(partial));
  h5::File& f = file();
  f.create_group(layout::run);
  h5::DatasetOptions early;
  early.allocate_early = true;
  state_rows_ = params_.finish ? std::size_t{kStateSize} : kLegacyStateSize;
  f.create_dataset(layout::run_state, h5::Type::Int64, state_rows_, 0, early)
      .write_rows(0, state_rows_, state_.data());
  for (const char* name : {"pointfair_format", "source_name"})
    f.set_attribute("/", name, in.string_attribute("/", name));
  for (const char* name : {"format_version", "source_size_bytes", "point_count", "tile_count"})
    f.set_attribute("/", name, in.int_attribute("/", name));
  f.set_attribute("/", "tool_version", version());
  f.copy_from(in, layout::points, layout::points);
  f.copy_from(in, layout::tiles, layout::tiles);

  f.set_attribute(layout::run, "parameters", key());
  f.set_attribute(layout::run, "input_digest", digest);
  f.set_attribute(layout::run, "input_name", input_path_.filename().string());
  f.set_attribute(layout::run, "input_size_bytes", static_cast<std::int64_t>(fs::file_size(input_path_)));
  f.set_attribute(layout::run, "tool_version", version());
  for (const std::string_view name : kSmoothStoredOrder)
    store_parameter(f, layout::run, name,
                    find_parameter<SmoothParams>(kSmoothParameters, &SmoothParameter::stored, name)->value(params_));

  f.create_dataset(layout::run_eps, h5::Type::Float64, 1, 0, early);
  f.create_dataset(layout::run_step_log, h5::Type::Float64, static_cast<std::uint64_t>(std::max(1, params_.steps)),
                   2, early);
  h5::DatasetOptions rows = early;
  rows.chunk_rows = std::min<std::uint64_t>(65536, std::max<std::uint64_t>(n_, 1));
  f.create_group("/run/neighbors");
  f.create_dataset(layout::neighbor_rows, h5::Type::UInt32, n_, static_cast<std::uint64_t>(k()), rows);
  f.create_dataset(layout::neighbor_counts, h5::Type::UInt16, n_, 0, rows);
  f.create_dataset(layout::neighbor_local, h5::Type::UInt32, n_, static_cast<std::uint64_t>(k()), rows);
  f.create_dataset(kLocalOrder, h5::Type::UInt32, n_, 0, rows);
  f.create_dataset(layout::neighbor_halo_counts, h5::Type::UInt64, std::max<std::uint64_t>(tiles_.size(), 1), 0,
                   early);
  f.create_dataset(positions_buffer(0), h5::Type::Float64, n_, 3, rows);
  f.create_dataset(positions_buffer(1), h5::Type::Float64, n_, 3, rows);
  if (momentum_on())
    for (const int parity : {0, 1}) f.create_dataset(moves_buffer(parity), h5::Type::Float64, n_, 3, rows);
  if (!options_.start_positions.empty()) {
    f.create_dataset(kStartPositions, h5::Type::Float64, n_, 3, rows);
    f.set_attribute(layout::run, "start_from", options_.start_positions.filename().string());
  }
  if (!options_.neighbor_reference.empty()) {
    f.create_dataset(kReferencePositions, h5::Type::Float64, n_, 3, rows);
    f.set_attribute(layout::run, "neighbors_from", options_.neighbor_reference.filename().string());
  }
  if (options_.attributes) {
    f.create_group(layout::run_attributes);
    const std::string a = layout::run_attributes;
    for (const char* name : {"normal", "d1", "d2"}) f.create_dataset(a + "/" + name, h5::Type::Float64, n_, 3, rows);
    for (const char* name : {"k1", "k2", "mean_curvature", "laplacian_norm"})
      f.create_dataset(a + "/" + name, h5::Type::Float64, n_, 0, rows);
    f.create_dataset(a + "/feature_class", h5::Type::UInt8, n_, 0, rows);
  }
  if (params_.finish) {
    f.create_dataset(kStopLambda, h5::Type::Float64, 1, 0, early);
    for (const QuadricParameter& parameter : kQuadricParameters)
      if (!parameter.stored.empty())
        store_parameter(f, layout::run, parameter.stored, parameter.value(*params_.finish));
    f.set_attribute(layout::run, "placement", stored_name_of(params_.placement));
  }
  state_.assign(kStateSize, 0);
  state_[kSetupDone] = 1;
  commit_state();
}

void Run::read_input_tables() {
  {
    const h5::File in = h5::File::open(input_path_, false);
    tiles_ = read_tile_table(in);
    n_ = point_count(in);
  }
  require(n_ < std::numeric_limits<Index>::max(), "a run holds fewer than 2^32-1 points");
  for (std::size_t t = 0; t < tiles_.size(); ++t) max_tile_rows_ = std::max(max_tile_rows_, tiles_.rows(t));
  global_bounds_ = cloud_bounds(tiles_);
}

namespace {

bool has_hdf5_signature(const fs::path& path) {
  char head[8] = {};
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return false;
  const std::size_t got = std::fread(head, 1, sizeof head, f);
  std::fclose(f);
  return got == sizeof head && std::memcmp(head, "\x89HDF\r\n\x1a\n", 8) == 0;
}

}  // namespace

std::string Run::input_digest() const {
  // Every row of the input's positions, in blocks of a fixed size, then the tile table: a
  // container of the same size with other coordinates or other tiles has another digest.
  std::uint64_t state = io::kDigestSeed;
  {
    const h5::File in = h5::File::open(input_path_, false);
    const h5::Dataset positions = in.dataset(layout::positions);
    constexpr std::uint64_t kRows = 1u << 16;
    std::vector<double> block;
    for (std::uint64_t first = 0; first < n_; first += kRows) {
      const std::uint64_t count = std::min(kRows, n_ - first);
      block.resize(3 * count);
      positions.read_rows(first, count, block.data());
      state = io::digest_update(state, block.data(), block.size() * sizeof(double));
    }
  }
  state = io::digest_update(state, tiles_.offsets.data(), tiles_.offsets.size() * sizeof(std::uint64_t));
  state = io::digest_update(state, tiles_.bounds.data(), tiles_.bounds.size() * sizeof(Box));
  std::string digest = io::digest_text(state);
  if (!options_.neighbor_reference.empty()) digest += " reference:" + io::file_digest(options_.neighbor_reference);
  if (!options_.start_positions.empty()) digest += " start:" + io::file_digest(options_.start_positions);
  return digest;
}

void Run::open_or_create() {
  if (ranks_->rank() != 0) return;  // the others open the file in share()

  const fs::path partial = partial_name(output_);
  // The run file is held exclusively (a lock) for the whole run: a second process, e.g. a
  // --resume started while this run still works, is refused before it reads or writes it.
  lock_.emplace(partial);
  const std::string digest = input_digest();
  // An empty file is the one the lock just made (or one left by a run killed before it wrote
  // anything): not a run.
  if (!lock_->created() && lock_->size_when_locked() > 0) {
    if (!options_.resume)
      throw io::IoError(partial.string() +
                        ": an interrupted run is in the way: pass --resume to continue it, or remove the file");
    bool usable = false;
    // Only a file this tool made is ever replaced: an HDF5 file with a run group (its state
    // record may be missing when it was killed while being created), or an HDF5 file that
    // libhdf5 cannot open (killed before its first flush). Anything else is the user's.
    bool ours = has_hdf5_signature(partial);
    try {
      file_.emplace(h5::File::open(partial, true));
      ours = file().exists(layout::run);
      if (ours && file().exists(layout::run_state)) {
        const auto st = file().dataset(layout::run_state).read_all<std::int64_t>();
        if ((st.size() == kStateSize || st.size() == kLegacyStateSize) && st[kSetupDone] == 1) {
          state_ = st;
          state_rows_ = st.size();
          state_.resize(kStateSize, 0);
          usable = true;
        }
      }
    } catch (const io::IoError&) {
      usable = false;
    }
    if (usable) {
      const std::string stored = file().string_attribute(layout::run, "parameters");
      const std::string current = key();
      if (stored != current)
        throw ParamError(partial.string() + " was started with other parameters (" +
                         detail::key_differences(stored, current) + "; the run's whole key: " + stored +
                         "): run with the run's values, or remove the file to start again");
      // Runs started before the digest was recorded are checked by their point count only.
      const bool other_input =
          point_count(file()) != n_ || (file().has_attribute(layout::run, "input_digest") &&
                                        file().string_attribute(layout::run, "input_digest") != digest);
      if (other_input)
        throw io::IoError(partial.string() + ": the interrupted run belongs to another input than " +
                          input_path_.string() +
                          " (its content differs): give the run's input, or remove the file to start again");
      return;
    }
    file_.reset();
    if (!ours)
      throw io::IoError(partial.string() +
                        ": not a run this tool can continue (not a pointfair run file, or damaged): it is "
                        "left alone; remove or rename it to start the run");
  }
  create(partial, digest);
}

OutOfCoreReport Run::run() {
  params_.validate();
  require(options_.memory_budget > 0, "the memory budget must be positive");
  require(options_.temporal_block >= 1, "the temporal block must be at least 1 step");
  require(options_.temporal_block == 1 || !(auto_lambda_on() && params_.lambda_every_step),
          "temporal blocks (--temporal-block) need a fixed lambda or one measured once (--lambda-schedule "
          "once): the automatic lambda of every step is measured on the whole cloud between steps");
  io::require_output_path(output_);
  io::require_distinct(input_path_, output_);
  io::require_distinct(input_path_, partial_name(output_));
  OutOfCoreReport report;
  read_input_tables();
  if (params_.neighbors.k == 0) {
    // The automatic k, measured on the input's positions (as smooth() does; on the start
    // positions when given), before the run file is created (its lists have k columns), also
    // on --resume. Every rank reads the input.
    params_.neighbors.k = k_for_noise_ratio(measure_noise().ratio);
  }
  report.k = k();
  open_or_create();
  share();
  report.points = n_;
  report.tiles = tiles_.size();
  auto t0 = Clock::now();
  balance(false);  // by points: the halos are not known yet
  if (state_[kNeighborsDone] == 0) {
    if (!options_.start_positions.empty()) {
      // Step 0's positions from the start, and the tiles' bounds around them.
      load_start();
      neighbor_source_ = kStartPositions;
      measure_bounds();
    }
    if (!options_.neighbor_reference.empty()) {
      // The first lists from the reference's positions, with halos around its tiles' bounds.
      load_reference();
      neighbor_source_ = kReferencePositions;
      measure_bounds();
    }
    build_neighbors(0);
  }
  else file().dataset(layout::run_eps).read_rows(0, 1, &eps_);
  report.eps = eps_;
  balance(true);
  report.halo_points = halo_points_;
  if (auto_lambda_on()) prepare_lambda_sample();
  report.seconds_neighbors = seconds_since(t0);
  report.steps = static_cast<int>(state_[kCompletedSteps]);
  const bool steps_done = run_steps(report);
  report.positions_held = holding_;
  release_positions();  // the finish and the attributes need the room
  release_scratch();
  // The lambda sample: the lambda of a run that took steps is in its step log from here on
  // (a run without steps measures it on the sample at the end).
  if (steps_done && final_steps_ > 0) {
    free_vector(sample_rows_);
    free_vector(sample_neighbors_);
    free_vector(sample_counts_);
    free_vector(sample_local_);
    free_vector(gather_rows_);
    free_vector(gather_positions_);
  }
  const bool finish_done = steps_done && run_finish(report);
  if (!finish_done) {
    report.neighbors_cached = caching_ && !ran_blocks_;
    report.tiles_in_flight = static_cast<int>(std::max(slots_, most_in_flight_));
    report.peak_accounted_bytes = peak_;
    report.largest_tile_with_halo = largest_local_;
    report.finish_tiles_in_parts = finish_tiles_in_parts_;
    file_.reset();
    return report;
  }
  // The threshold of the last step (or of the input when there are no steps).
  double lambda = params_.flow.lambda;
  report.steps = final_steps_;
  if (final_steps_ > 0) {
    double entry[2];
    file().dataset(layout::run_step_log).read_rows(static_cast<std::uint64_t>(final_steps_ - 1), 1, entry);
    // Stopped early: smooth() reports the threshold measured on the final positions.
    lambda = final_steps_ < params_.steps ? stop_lambda_ : entry[0];
    report.degenerate = static_cast<std::size_t>(entry[1]);
  } else if (auto_lambda_on()) {
    load_sample_positions(file().dataset(step0_source()));
    lambda = sample_lambda();
  }
  report.lambda = lambda;
  t0 = Clock::now();
  const std::size_t attributes_degenerate = options_.attributes ? write_attributes(lambda) : 0;
  report.seconds_attributes = seconds_since(t0);
  release();
  if (ranks_->rank() == 0) finish(attributes_degenerate, lambda);
  ranks_->barrier();  // the run is in place when any rank returns
  report.finished = true;
  report.neighbors_cached = caching_ && !ran_blocks_;
  report.tiles_in_flight = static_cast<int>(std::max(slots_, most_in_flight_));
  report.peak_accounted_bytes = peak_;
  report.largest_tile_with_halo = largest_local_;
  report.finish_tiles_in_parts = finish_tiles_in_parts_;
  return report;
}

}  // namespace pointfair::tiles::detail
