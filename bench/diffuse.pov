// bench/diffuse.pov: scenes/diffuse.cfg written for POV-Ray 3.7, for `make bench`.
//
// Render (what the benchmark, bench/rayd_bench, does):
//   povray +Ibench/diffuse.pov +O/tmp/diffuse.png +W1920 +H1080 -D -A +WT1 File_Gamma=1.0
//
// Same as the cfg (the same numbers, in the same right-handed coordinates):
//   - camera eye/target/up; the cfg's 40 degree VERTICAL fov becomes POV-Ray's
//     horizontal `angle` 2*atan(16/9 * tan(20 deg)) = 65.81 deg, with `right`
//     16/9 wide, so it is only right for a 16:9 image such as 1920x1080;
//   - `right` is NEGATIVE x: the cfg is right-handed (x right, y up, camera on
//     +z looking to -z); POV-Ray is left-handed by default and would show the
//     scene mirrored (red sphere on the right). -x is POV-Ray's documented
//     switch to a right-handed camera; every coordinate is then copied as is;
//   - two point lights, same positions and colours, no distance attenuation
//     (POV-Ray's default fade_power 0), hard shadows (no area lights);
//   - Lambert: pigment kd, `diffuse 1` (brilliance 1, i.e. kd * cos(angle),
//     exactly rayd's diffuse), no specular, no phong;
//   - ambient: rayd adds the material's ambient as is; POV-Ray multiplies the
//     finish's ambient by the pigment, so the finish gets ambient/kd per
//     channel, which gives exactly the cfg's ambient;
//   - background colour, no antialiasing (-A, one ray through each pixel
//     centre), no radiosity, no photons, no media, max_trace_level 5 (these
//     scenes have no mirrors, so no secondary rays in either renderer);
//   - gamma 1 (assumed_gamma 1.0 here, File_Gamma=1.0 on the command line):
//     8-bit = round(clamp(c)*255), as rayd with the cfg's default gamma 1.
// Not the same:
//   - POV-Ray is a general renderer: bounding hierarchy (only 3 spheres, the
//     plane is unbounded), a per-light "last occluder" shadow cache, texture
//     and finish layers, checks for transparency etc. Per ray it does more
//     bookkeeping and less (cache hits) work than rayd; the work is not
//     instruction-for-instruction equal, but the rays are: both skip the
//     shadow ray when a light is behind the surface, and at 1920x1080 both
//     trace 2073600 camera + 2912594 shadow rays (POV-Ray's "Shadow Ray Tests");
//   - self-intersection tolerances differ (none showed here). Checked at
//     1920x1080 against rayd's PNG: all but 20 (diffuse) / 15 (phong) pixels
//     are identical, and those differ by 1/255 in one channel (rounding);
//   - POV-Ray writes its PNG with a gAMA chunk; rayd's PNG has none.
#version 3.7;

global_settings {
  assumed_gamma 1.0
  ambient_light rgb 1
  max_trace_level 5
}

camera {
  perspective
  location <0, 2.5, 9>
  look_at  <0, 1, 0>
  sky      <0, 1, 0>
  up       y
  right    -x*16/9
  angle    2*degrees(atan(16/9*tan(radians(40/2))))
}

background { rgb <0.05, 0.05, 0.1> }

light_source { <6, 10, 8>  color rgb <0.8, 0.8, 0.8> }   // key
light_source { <-8, 6, 4>  color rgb <0.3, 0.3, 0.35> }  // fill

// rayd `diffuse`: kd * cos + ambient.
#macro Lambert(Kd, Ka)
  texture {
    pigment { rgb Kd }
    finish { ambient rgb Ka/Kd diffuse 1 brilliance 1 specular 0 phong 0 reflection 0 }
  }
#end

sphere { <-2.2, 1, 0>,   1   Lambert(<0.8, 0.15, 0.1>, <0.05, 0.01, 0.01>) }  // red
sphere { <0, 1.2, -1>,   1.2 Lambert(<0.15, 0.7, 0.2>, <0.01, 0.05, 0.01>) }  // green
sphere { <2.2, 0.8, 0.8>, 0.8 Lambert(<0.1, 0.2, 0.8>,  <0.01, 0.01, 0.05>) } // blue
plane  { <0, 1, 0>, 0    Lambert(<0.7, 0.7, 0.7>,  <0.04, 0.04, 0.04>) }      // floor
