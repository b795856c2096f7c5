// StagedOutputs (core/staged_outputs.h): outputs appear together or not at all, and a failure in
// the middle of the commit gives the targets already renamed their old content back.
#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/core/staged_outputs.h>

#include "test_support.h"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace diffreg;
using namespace diffreg::testing;
namespace fs = std::filesystem;

namespace {

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST_CASE("a rename that fails in the commit restores the outputs renamed before it",
          "[core][hostile]") {
  TempDir tmp;
  const std::string a = tmp.file("a.txt", "old a");
  const std::string b = tmp / "b.txt";  // does not exist yet
  const std::string c = tmp / "c.txt";
  {
    StagedOutputs staged;
    staged.stageText(a, "new a");
    staged.stageText(b, "new b");
    staged.stageText(c, "new c");
    // c becomes a non-empty directory after the checks: renaming onto it fails.
    fs::create_directories(fs::path(c) / "x");
    CHECK_THROWS_AS(staged.commit(), IoError);
  }
  CHECK(read(a) == "old a");
  CHECK_FALSE(fs::exists(b));
  CHECK(fs::is_directory(c));
  CHECK(tmp.entries() == 2);  // a.txt and c.txt/: no temporary or backup left
}

TEST_CASE("one output under two spellings is staged once", "[core][hostile]") {
  TempDir tmp;
  StagedOutputs staged;
  staged.stage(tmp / "a.ply");
  CHECK_THROWS_AS(staged.stage((tmp.path / "." / "a.ply").string()), InvalidParameter);
  CHECK(canonicalTarget(tmp / "a.ply") ==
        canonicalTarget((tmp.path / "x" / ".." / "a.ply").string()));
}

TEST_CASE("an output that is a symbolic link stays one", "[core][hostile]") {
  TempDir tmp;
  fs::create_directories(tmp.path / "data");
  const std::string real = tmp.file("data/real.ply", "old");
  const std::string link = tmp / "out.ply";
  fs::create_symlink("data/real.ply", link);
  {
    StagedOutputs staged;
    staged.stageText(link, "new");
    // The link and the file it leads to are one output.
    CHECK_THROWS_AS(staged.stage(real), InvalidParameter);
    staged.commit();
  }
  CHECK(fs::is_symlink(link));
  CHECK(read(real) == "new");
  // No temporary or backup is left: out.ply and data/ beside each other, real.ply alone in data/.
  CHECK(tmp.entries() == 2);
  CHECK(std::distance(fs::directory_iterator(tmp.path / "data"), fs::directory_iterator()) == 1);
}

TEST_CASE("an output link to a file of another extension is written in the output's format",
          "[core][hostile]") {
  // -o res.ply asks for PLY: that res.ply leads to res.obj does not make it OBJ.
  TempDir tmp;
  const std::string real = tmp.file("res.obj", "");
  const std::string link = tmp / "res.ply";
  fs::create_symlink("res.obj", link);
  StagedOutputs staged;
  const std::string temporary = staged.stage(link);
  CHECK(fs::path(temporary).extension() == ".ply");
  CHECK(fs::path(temporary).parent_path() == fs::path(real).parent_path());
}

TEST_CASE("a staged write that fails names the output, not its temporary", "[core][hostile]") {
  TempDir tmp;
  const std::string out = tmp / "out.ply";
  StagedOutputs staged;
  std::string temporary;
  try {
    staged.stageWritten(out, [&temporary](const std::string& t) {
      temporary = t;
      throw IoError("cannot write '" + t + "': No space left on device");
    });
    FAIL("no error");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()) == "cannot write '" + out + "': No space left on device");
  }
  CHECK(temporary != out);
}

TEST_CASE("what a staged write warns, and a mesh error it throws, name the output",
          "[core][hostile]") {
  TempDir tmp;
  const std::string out = tmp / "out.ply";
  StagedOutputs staged;
  std::string temporary;
  const std::string err = stderrOf([&] {
    staged.stageWritten(out, [&temporary](const std::string& t) {
      temporary = t;
      warn("writing '" + t + "': a property left out");
    });
  });
  CHECK(err == "diffreg: warning: writing '" + out + "': a property left out\n");
  CHECK(temporary.find(".out.tmp-") != std::string::npos);
  // Warnings before a failure are said too; the failure keeps its type.
  const std::string bad = tmp / "bad.ply";
  const std::string said = stderrOf([&] {
    CHECK_THROWS_WITH(
        staged.stageWritten(bad,
                            [](const std::string& t) {
                              warn("writing '" + t + "': first");
                              throw InvalidMesh("cannot write '" + t + "': non-finite coordinates");
                            }),
        "cannot write '" + bad + "': non-finite coordinates");
  });
  CHECK(said == "diffreg: warning: writing '" + bad + "': first\n");
  CHECK_THROWS_AS(
      staged.stageWritten(tmp / "c.ply",
                          [](const std::string& t) { throw InvalidMesh("'" + t + "'"); }),
      InvalidMesh);
}

TEST_CASE("staged outputs of one process do not collide, whatever the working directory does",
          "[core][hostile]") {
  TempDir tmp;
  fs::create_directories(tmp.path / "d");
  // Two sets staging the same target (two threads of one process), and two targets that would
  // share a temporary name (the link's destination stem with the output's extension).
  fs::create_symlink("d/real.dat", tmp.path / "x.png");
  StagedOutputs first, second;
  const std::string t1 = first.stage(tmp / "same.png");
  const std::string t2 = second.stage(tmp / "same.png");
  const std::string t3 = first.stage(tmp / "x.png");
  const std::string t4 = first.stage(tmp / "d/real.png");
  CHECK(t1 != t2);
  CHECK(t3 != t4);
  for (const auto& t : {t1, t2, t3, t4}) CHECK(fs::path(t).is_absolute());
  std::ofstream(t1) << "one";
  std::ofstream(t2) << "two";
  std::ofstream(t3) << "three";
  std::ofstream(t4) << "four";
  second.commit();
  // A relative output stays where it was given, though the working directory changes before
  // the commit.
  const fs::path before = fs::current_path();
  fs::current_path(tmp.path);
  StagedOutputs relative;
  const std::string t5 = relative.stage("rel.txt");
  fs::current_path(tmp.path / "d");
  std::ofstream(t5) << "rel";
  relative.commit();
  first.commit();
  fs::current_path(before);
  CHECK(read(tmp / "same.png") == "one");
  CHECK(read(tmp / "d/real.dat") == "three");
  CHECK(read(tmp / "d/real.png") == "four");
  CHECK(read(tmp / "rel.txt") == "rel");
  CHECK_FALSE(fs::exists(tmp.path / "d" / "rel.txt"));
  CHECK(tmp.entries() == 4);  // d/, x.png, same.png, rel.txt: no temporary left
  CHECK(std::distance(fs::directory_iterator(tmp.path / "d"), fs::directory_iterator()) == 2);
}
